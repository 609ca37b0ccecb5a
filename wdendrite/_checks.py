"""Input validation shared by the public functions.

Each helper raises ``ValueError`` (bad value or shape) or ``TypeError`` (bad
type or dtype) with a message that names the parameter and what it received.
"""

from __future__ import annotations

import contextlib
import contextvars
import math
import os

import numpy as np
import warp as wp


def lattice_shape(shape, *, ranks: tuple[int, ...] = (2, 3), whole: bool = True) -> tuple[int, ...]:
    """Return ``shape`` as a tuple of positive ints, of one of the ``ranks`` (2: (H, W), 3: (D, H, W)).

    Every size must fit an int32. With ``whole`` (a lattice, made at once) the number of nodes
    must too; an image made window by window can hold more pixels.
    """
    names = {2: "rank 2 (H, W)", 3: "rank 3 (D, H, W)"}
    want = " or ".join(names[r] for r in ranks)
    try:
        dims = tuple(shape)
    except TypeError:
        raise TypeError(f"Expected a tuple {' or '.join(names[r][7:] for r in ranks)} for 'shape', but got "
                        f"{shape!r}") from None
    if len(dims) not in ranks:
        raise ValueError(f"Expected 'shape' of {want}, but got {shape!r} (rank {len(dims)})")
    out = []
    for n in dims:
        if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)):
            raise TypeError(f"Expected integer sizes in 'shape', but got {shape!r}")
        if n <= 0:
            raise ValueError(f"Expected positive sizes in 'shape', but got {shape!r}")
        if n >= 2**31:
            raise ValueError(f"'shape' {shape!r} has a size of {int(n)}; at most 2**31 - 1 is supported")
        out.append(int(n))
    if whole and math.prod(out) >= 2**31:
        raise ValueError(f"'shape' {shape!r} has {math.prod(out)} nodes; at most 2**31 - 1 are supported")
    return tuple(out)


def float_array(
    name: str, value, shape: tuple[int, ...], *, positive: bool = False, check_values: bool = True,
    shape_note: str = "",
) -> np.ndarray:
    """Return ``value`` as a float32 array of ``shape`` whose entries are finite and >= 0 (> 0).

    With ``check_values=False`` only the dtype and shape are checked; ``shape_note`` ends the
    message about a wrong shape (what the shape's parts are).
    """
    unmasked(name, value)
    arr = np.asarray(value)
    if arr.dtype.kind not in "fiu" or arr.dtype == np.bool_:
        raise TypeError(f"Expected a real-valued array for '{name}', but got dtype {arr.dtype}")
    if arr.shape != tuple(shape):
        raise ValueError(f"Expected '{name}' of shape {tuple(shape)}, but got shape {arr.shape}{shape_note}")
    raw = arr
    with np.errstate(over="ignore"):  # values beyond float32 become inf: reported below, not warned about
        arr = np.ascontiguousarray(arr, dtype=np.float32)
    if not check_values:
        return arr
    if arr.size:
        lo, hi = float(arr.min()), float(arr.max())
        # the common case costs two reductions; the slow scans below only name the culprit
        if math.isfinite(lo) and math.isfinite(hi) and (lo > 0 if positive else lo >= 0):
            return arr
    bad = ~np.isfinite(arr)
    if bad.any():
        where = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ValueError(f"'{name}' must be finite, but has {int(bad.sum())} NaN/inf entries "
                         f"(first at {where}: {raw[where].item()!r}{float32_note(raw[where])})")
    low = arr <= 0 if positive else arr < 0
    if low.any():
        where = tuple(int(i) for i in np.argwhere(low)[0])
        kind = "positive" if positive else "non-negative"
        raise ValueError(f"'{name}' must be {kind}, but has value {raw[where].item()!r}{float32_note(raw[where])} "
                         f"at index {where}")
    return arr


def float32_note(value) -> str:
    """Why a finite, non-zero ``value`` is not itself in float32 (empty when it is): too large
    (it becomes inf) or too small (it becomes 0)."""
    v = float(value)
    if not math.isfinite(v) or v == 0:
        return ""
    if abs(v) > float(np.finfo(np.float32).max):
        return " (too large for float32)"
    if np.float32(v) == 0:
        return " (too small for float32: it becomes 0)"
    return ""


def unmasked(name: str, value) -> None:
    """Refuse a NumPy masked array with masked cells (a DEM's nodata): converting it would drop the
    mask silently and use whatever the masked cells hold."""
    if np.ma.isMaskedArray(value) and np.ma.getmaskarray(value).any():
        raise ValueError(f"'{name}' is a masked array with {int(np.ma.getmaskarray(value).sum())} masked cells "
                         f"(nodata?), which have no value to use; drop or fill them first, e.g. {name}.filled(fill_value)")


def finite_array(name: str, value, shapes: str, shape_ok, *, kinds: str = "fiu", dtype=np.float32) -> np.ndarray:
    """``value`` as a C-contiguous ``dtype`` array that is non-empty, finite and of a shape ``shape_ok`` accepts.

    Args:
        name: the parameter, for the error messages.
        value: array-like.
        shapes: the accepted shapes in words, e.g. ``"2D (H, W)"``.
        shape_ok: ``shape -> bool``.
        kinds: accepted NumPy dtype kinds (``"b"`` admits bool arrays).
        dtype: the returned array's dtype (None: the input's); values too large for it count as infinite.

    Raises:
        TypeError: a dtype outside ``kinds`` (text, objects).
        ValueError: ragged nested sequences, an empty array, a shape ``shape_ok`` refuses, NaN or inf
            entries, a masked array with masked cells (see :func:`unmasked`).
    """
    unmasked(name, value)
    try:
        raw = np.asarray(value)
    except ValueError:  # nested sequences of different lengths
        raise ValueError(f"Expected a {shapes} array for '{name}', but got rows of different lengths: "
                         f"{value!r:.200}") from None
    if raw.dtype.kind not in kinds:
        raise TypeError(f"Expected a real-valued {shapes} array for '{name}', but got dtype {raw.dtype} "
                        f"(shape {raw.shape})")
    if raw.size == 0 or not shape_ok(raw.shape):
        raise ValueError(f"Expected a non-empty {shapes} array for '{name}', but got shape {raw.shape}")
    with np.errstate(over="ignore"):
        arr = np.ascontiguousarray(raw, dtype=dtype)
    bad = ~np.isfinite(arr)
    if bad.any():
        first = tuple(int(i) for i in np.argwhere(bad)[0])
        v = raw[first].item()
        why = f" (too large for {np.dtype(dtype).name})" if math.isfinite(v) else ""
        if np.isfinite(raw[bad]).all():  # finite values that only the conversion made infinite
            raise ValueError(f"'{name}' must fit in {np.dtype(dtype).name}, but has {int(bad.sum())} entries "
                             f"beyond its range (first at {first}: {v!r}{why})")
        raise ValueError(f"'{name}' must be finite, but has {int(bad.sum())} NaN/inf entries "
                         f"(first at {first}: {v!r}{why})")
    return arr


def bool_array(name: str, value, shape: tuple[int, ...]) -> np.ndarray:
    """Return ``value`` as a C-contiguous bool array of ``shape``."""
    unmasked(name, value)
    arr = np.asarray(value)
    if arr.dtype != np.bool_:
        hint = f" (from a 0/1 or 0/255 image, pass {name} > 0)" if arr.dtype.kind in "iuf" else ""
        raise TypeError(f"Expected a bool array for '{name}', but got dtype {arr.dtype}{hint}")
    if arr.shape != tuple(shape):
        raise ValueError(f"Expected '{name}' of shape {tuple(shape)}, but got shape {arr.shape}")
    return np.ascontiguousarray(arr)


def integer_array(name: str, value, what: str = "values") -> np.ndarray:
    """Return ``value`` as an int64 array; a non-integer dtype (bool included) is a TypeError
    naming ``what`` the integers are. Empty arrays of any dtype pass (``np.asarray([])`` is float).
    Ragged nested sequences and unsigned values beyond int64 are ValueErrors naming ``name``."""
    unmasked(name, value)
    try:
        arr = np.asarray(value)
    except ValueError:  # nested sequences of different lengths
        raise ValueError(f"Expected integer {what} for '{name}' in rows of one length, but got rows of different "
                         f"lengths: {value!r:.200}") from None
    if arr.size and (arr.dtype.kind not in "iu" or arr.dtype == np.bool_):
        raise TypeError(f"Expected integer {what} for '{name}', but got dtype {arr.dtype}")
    top = np.iinfo(np.int64).max
    if arr.dtype.kind == "u" and arr.size and arr.max() > top:  # (the cast below would wrap them to negatives)
        where = tuple(int(i) for i in np.argwhere(arr > top)[0])
        raise ValueError(f"'{name}' has {what} beyond int64: {arr[where].item()!r} at index {where}")
    return arr.astype(np.int64)


def face_indices(name: str, value, n_vertices: int) -> np.ndarray:
    """``value`` as an ``(F, 3)`` int64 array of vertex indices in ``[0, n_vertices)``.

    Raises:
        TypeError: a non-integer dtype (bool included).
        ValueError: another shape, an index outside ``[0, n_vertices)`` (a mesh built with
            ``process=False`` keeps any, and what reads it then reads out of bounds).
    """
    raw = np.asarray(value)
    arr = integer_array(name, raw, "vertex indices")
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"Expected '{name}' of shape (F, 3), but got shape {raw.shape}")
    if raw.size:
        lo, hi = raw.min(), raw.max()
        if lo < 0 or hi >= n_vertices:
            raise ValueError(f"Expected '{name}' indices in [0, {n_vertices}), but got {int(lo if lo < 0 else hi)}")
    return arr


def node_coordinates(name: str, value, shape: tuple[int, ...], mask: np.ndarray | None = None) -> np.ndarray:
    """Return ``value`` as a ``(G, ndim)`` int64 array of in-bounds, usable nodes."""
    arr = integer_array(name, value, "coordinates")
    ndim = len(shape)
    if arr.ndim != 2 or arr.shape[1] != ndim:
        raise ValueError(
            f"Expected '{name}' of shape (G, {ndim}) for a lattice of shape {shape}, but got shape {arr.shape}"
            + (" (use [point] for a single point)" if arr.ndim == 1 and arr.shape[0] == ndim else "")
        )
    if arr.shape[0] == 0:
        raise ValueError(f"'{name}' is empty: at least one node is needed")
    outside = np.any((arr < 0) | (arr >= np.asarray(shape)), axis=1)
    if outside.any():
        row = int(np.argmax(outside))
        point = tuple(arr[row].tolist())
        hint = ""
        if len(shape) == 2 and all(0 <= v < n for v, n in zip(point[::-1], shape)):
            hint = f"; coordinates are (row, col) = (y, x): did you mean {point[::-1]}?"
        raise ValueError(f"'{name}' row {row} = {point} lies outside the lattice of shape {shape}{hint}")
    if mask is not None:
        blocked = ~mask[tuple(arr.T)]
        if blocked.any():
            row = int(np.argmax(blocked))
            raise ValueError(f"'{name}' row {row} = {tuple(arr[row].tolist())} is a masked-out node")
    return arr


def _number(name: str, value) -> float:
    """``value`` as a float; bools and text are refused (``float("2")`` parses, but "2" * 3 fails later)."""
    if isinstance(value, (bool, np.bool_, str, bytes)):
        raise TypeError(f"Expected a number for '{name}', but got {value!r}")
    try:
        return float(value)
    except (TypeError, ValueError):
        raise TypeError(f"Expected a number for '{name}', but got {value!r}") from None


def finite(name: str, value) -> float:
    """Return ``value`` as a finite float (bools and text are refused: they are not numbers here)."""
    x = _number(name, value)
    if not math.isfinite(x):
        raise ValueError(f"Expected a finite number for '{name}', but got {value!r}")
    return x


def nonnegative(name: str, value, *, allow_none: bool = True, allow_inf: bool = False) -> float | None:
    """Return ``value`` as a float >= 0 (None passes through when allowed; bools and text are refused)."""
    if value is None and allow_none:
        return None
    x = _number(name, value)
    if math.isnan(x) or x < 0 or (math.isinf(x) and not allow_inf):
        raise ValueError(f"Expected a non-negative {'' if allow_inf else 'finite '}number for '{name}', but got {value!r}")
    return x


def positive(name: str, value) -> float:
    """Return ``value`` as a finite float > 0."""
    x = _number(name, value)
    if not (0 < x < math.inf):  # (NaN fails too)
        raise ValueError(f"Expected a positive finite number for '{name}', but got {value!r}")
    return x


def available_bytes(device) -> int:
    """Memory a new allocation on ``device`` can use, in bytes: on the CPU the least of the
    system's available memory and the room left under the limits set on this process
    (:func:`host_limit`)."""
    device = wp.get_device(device)
    if device.is_cuda:
        return int(device.free_memory)
    have = None
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    have = int(line.split()[1]) * 1024
                    break
    except (OSError, ValueError, IndexError):
        pass
    if have is None:
        have = int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_AVPHYS_PAGES"))
    room = host_limit()[0]
    return have if room is None else min(have, room)


_NO_LIMIT = 2**60  # cgroup v1 writes "no limit" as the largest page multiple below 2**63


def host_limit(*, status: str = "/proc/self/status", cgroup: str = "/proc/self/cgroup",
               root: str = "/sys/fs/cgroup") -> tuple[int | None, str]:
    """The bytes this process may still allocate under the limits set on it, and which limit
    that is: its address-space limit (``RLIMIT_AS``, ``ulimit -v``: the limit less the address
    space it already maps, ``VmSize`` in ``status``) and its cgroup's memory limit (cgroup v2
    ``memory.max``, v1 ``memory.limit_in_bytes``, of its cgroup and each one above it under
    ``root``, less the memory charged there, of which inactive file cache counts as free:
    the system reclaims it first). ``(None, "")`` when no limit applies. The keywords point
    at other files (for tests)."""
    found = []
    try:
        import resource

        soft = resource.getrlimit(resource.RLIMIT_AS)[0]
    except (ImportError, OSError, ValueError):
        soft = None
    if soft is not None and soft != resource.RLIM_INFINITY:
        found.append((soft - _status_bytes(status, "VmSize:"), f"the address-space limit of {soft / 2**30:.2f} GiB "
                                                               "(ulimit -v) less what the process maps"))
    for room, where in _cgroup_rooms(cgroup, root):
        found.append((room, f"the memory limit of cgroup {where}"))
    if not found:
        return None, ""
    room, why = min(found)
    return max(0, room), why


def _status_bytes(status: str, key: str) -> int:
    try:
        with open(status) as f:
            for line in f:
                if line.startswith(key):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return 0


def _cgroup_rooms(cgroup: str, root: str):
    """``(bytes left, cgroup)`` for each memory-limited cgroup this process belongs to (its own and
    those above it), v2 and v1."""
    try:
        with open(cgroup) as f:
            lines = f.read().splitlines()
    except OSError:
        return
    for line in lines:
        parts = line.split(":", 2)
        if len(parts) != 3:
            continue
        if parts[0] == "0" and parts[1] == "":  # v2: one hierarchy
            base, files = root, ("memory.max", "memory.current", "inactive_file")
        elif "memory" in parts[1].split(","):  # v1: the memory controller's own hierarchy
            base, files = os.path.join(root, "memory"), ("memory.limit_in_bytes", "memory.usage_in_bytes",
                                                          "total_inactive_file")
        else:
            continue
        here = os.path.normpath(os.path.join(base, parts[2].lstrip("/")))
        if not here.startswith(os.path.normpath(base)) or not os.path.isdir(here):
            here = base  # a container sees its own cgroup at the root (another one's path is not mounted)
        while True:
            room = _cgroup_room(here, *files)
            if room is not None:
                yield room, here
            if os.path.normpath(here) == os.path.normpath(base):
                break
            here = os.path.dirname(here)


def _cgroup_room(folder: str, limit_file: str, usage_file: str, inactive_key: str) -> int | None:
    def number(name):
        try:
            with open(os.path.join(folder, name)) as f:
                text = f.read().strip()
        except OSError:
            return None
        return int(text) if text.isdigit() else None

    limit, usage = number(limit_file), number(usage_file)
    if limit is None or limit >= _NO_LIMIT or usage is None:
        return None
    inactive = 0
    try:
        with open(os.path.join(folder, "memory.stat")) as f:
            for line in f:
                key, _, value = line.partition(" ")
                if key == inactive_key and value.strip().isdigit():
                    inactive = int(value)
    except OSError:
        pass
    return limit - usage + inactive


def fits_in_memory(need: int, device, what: str) -> None:
    """Raise ``MemoryError`` when ``need`` bytes exceed what ``device`` has free (on the CPU, also
    under the process's address-space and cgroup limits: see :func:`available_bytes`)."""
    device = wp.get_device(device)
    have = available_bytes(device)
    if need > have and device.is_cuda:
        # CUDA's memory pool keeps freed blocks until the next synchronization (its default
        # release threshold is 0): count them as free once it has let them go
        wp.synchronize_device(device)
        have = available_bytes(device)
    if need > have:
        room, why = (None, "") if device.is_cuda else host_limit()
        raise MemoryError(
            f"{what} needs about {need / 2**30:.2f} GiB on device '{device}', "
            f"but only {have / 2**30:.2f} GiB are available" + (f" under {why}" if room == have else "")
        )


def memory_error(exc: BaseException) -> MemoryError | None:
    """``exc`` as a :class:`MemoryError` when it is an allocation that failed under another name
    (``OSError`` ENOMEM from a memory map, Warp's ``RuntimeError: Failed to allocate``), else None."""
    import errno

    if isinstance(exc, MemoryError):
        return exc
    if isinstance(exc, OSError) and exc.errno == errno.ENOMEM:
        return MemoryError(exc.strerror or str(exc))
    if isinstance(exc, RuntimeError) and str(exc).startswith("Failed to allocate"):
        return MemoryError(str(exc))
    return None


def device(value, name: str = "device"):
    """``value`` as a Warp device (None: Warp's default); an unknown or absent one is a ValueError."""
    if value is None or isinstance(value, wp.Device):
        return wp.get_device(value)
    known = [str(d) for d in wp.get_devices()]
    # asking Warp for a CUDA device on a machine without one prints driver errors before it raises
    if not isinstance(value, str) or (value.startswith("cuda") and value not in known and value != "cuda") or (
        value == "cuda" and wp.get_cuda_device_count() == 0
    ):
        raise ValueError(f"Expected a Warp device for '{name}' (one of {', '.join(known)}), but got {value!r}")
    try:
        return wp.get_device(value)
    except (RuntimeError, ValueError) as e:
        raise ValueError(f"Expected a Warp device for '{name}' (one of {', '.join(known)}), but got {value!r}: {e}") from None


def flag(name: str, value) -> bool:
    """``value`` as a Python bool; only bools (Python or NumPy) are taken: text such as ``"no"``
    would count as true, and 0 or 1 may be a slip for another parameter."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"Expected a bool for '{name}', but got {value!r}")
    return bool(value)


def integer(name: str, value, *, low: int | None = None, high: int | None = None) -> int:
    """``value`` as a Python int (bools, floats and text refused), in ``[low, high]`` where given."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"Expected an integer for '{name}', but got {value!r}")
    if (low is not None and value < low) or (high is not None and value > high):
        span = f"in [{low}, {high}]" if low is not None and high is not None else (
            f">= {low}" if low is not None else f"<= {high}")
        raise ValueError(f"Expected '{name}' {span}, but got {value!r}")
    return int(value)


def seed32(seed, name: str = "seed") -> int:
    """``seed`` as a Python int in [0, 2**32): the seeds that kernels hash (weights, Dendry, noise)."""
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        raise TypeError(f"Expected an integer '{name}', but got {seed!r}")
    if not 0 <= int(seed) < 2**32:
        raise ValueError(f"Expected '{name}' in [0, 2**32), but got {seed!r}")
    return int(seed)


def rng(seed, name: str = "seed") -> np.random.Generator:
    """A NumPy generator from ``seed``: a non-negative int, or a ``np.random.Generator`` (used as is)."""
    if isinstance(seed, np.random.Generator):
        return seed
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        raise TypeError(f"Expected an int or a numpy.random.Generator for '{name}', but got {seed!r}")
    if seed < 0:
        raise ValueError(f"Expected a non-negative '{name}', but got {seed!r}")
    return np.random.default_rng(int(seed))


class Checked(BaseException):
    """Raised by :func:`stop_if_checking` inside :func:`checking_only`: the work was about to begin.

    Not an :class:`Exception`, so that no ``except Exception`` on the way up takes it for a failure
    and carries on with the work."""


_CHECKING = contextvars.ContextVar("wdendrite_checking_only", default=False)


@contextlib.contextmanager
def checking_only():
    """Run code only up to its first real work: inside, :func:`stop_if_checking` raises :class:`Checked`.

    A preset's function called in this context checks its arguments (and those of the
    lattice it builds) and stops when its first :class:`~wdendrite.Lattice` is about to be
    filled or its Dendry image computed: what a batch does with every task before running any.
    """
    token = _CHECKING.set(True)
    try:
        yield
    finally:
        _CHECKING.reset(token)


def stop_if_checking() -> None:
    """Raise :class:`Checked` inside :func:`checking_only` (called where work begins)."""
    if _CHECKING.get():
        raise Checked()
