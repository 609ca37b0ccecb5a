"""The memory pre-check under the limits set on a process: RLIMIT_AS (ulimit -v) and cgroups."""

import errno
import resource
import subprocess
import sys

import pytest

from wdendrite import _checks, cli

PY = sys.executable


def _tree(root, files: dict):
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


@pytest.fixture
def no_address_limit():
    if resource.getrlimit(resource.RLIMIT_AS)[0] != resource.RLIM_INFINITY:
        pytest.skip("this process has an address-space limit of its own")


def test_the_limit_of_a_cgroup_and_those_above_it_is_read_in_v2_and_v1(tmp_path, no_address_limit):
    own = tmp_path / "cgroup"
    # v2: the cgroup's own limit leaves 600 kB (+ 50 kB of inactive file cache); its parent's, 100 kB
    _tree(tmp_path / "v2", {"a/b/memory.max": "1000000\n", "a/b/memory.current": "400000\n",
                            "a/b/memory.stat": "anon 1\ninactive_file 50000\n", "a/memory.max": "800000\n",
                            "a/memory.current": "700000\n", "memory.max": "max\n", "memory.current": "5\n"})
    own.write_text("0::/a/b\n")
    assert _checks.host_limit(cgroup=own, root=tmp_path / "v2") == (100000, f"the memory limit of cgroup "
                                                                            f"{tmp_path / 'v2' / 'a'}")
    (tmp_path / "v2" / "a" / "memory.max").write_text("max\n")
    assert _checks.host_limit(cgroup=own, root=tmp_path / "v2")[0] == 650000
    own.write_text("0::/elsewhere\n")  # a container sees its own cgroup at the root
    (tmp_path / "v2" / "memory.max").write_text("4096\n")
    assert _checks.host_limit(cgroup=own, root=tmp_path / "v2")[0] == 4096 - 5
    # v1: the memory controller's hierarchy; "no limit" is written as a huge number
    _tree(tmp_path / "v1", {"memory/x/memory.limit_in_bytes": "2000\n", "memory/x/memory.usage_in_bytes": "500\n",
                            "memory/x/memory.stat": "cache 7\ntotal_inactive_file 100\n",
                            "memory/memory.limit_in_bytes": "9223372036854771712\n",
                            "memory/memory.usage_in_bytes": "123\n"})
    own.write_text("5:cpu,cpuacct:/x\n4:memory:/x\n0::/\n")
    assert _checks.host_limit(cgroup=own, root=tmp_path / "v1")[0] == 1600
    own.write_text("4:memory:/\n")
    assert _checks.host_limit(cgroup=own, root=tmp_path / "v1") == (None, "")


def test_an_address_space_limit_counts_what_the_process_maps_already(tmp_path, no_address_limit):
    status = tmp_path / "status"
    status.write_text("Name:\tpython\nVmPeak:\t  900000 kB\nVmSize:\t  800000 kB\n")
    code = ("import resource, sys; from wdendrite import _checks\n"
            "resource.setrlimit(resource.RLIMIT_AS, (2**30, resource.RLIM_INFINITY))\n"
            "print(_checks.host_limit(status=sys.argv[1], cgroup='/nonexistent')[0])")
    got = subprocess.run([PY, "-c", code, str(status)], capture_output=True, text=True, check=True)
    assert int(got.stdout.split()[-1]) == 2**30 - 800000 * 1024


def _under_address_limit(args, limit, cwd):
    def limited():
        resource.setrlimit(resource.RLIMIT_AS, (limit, resource.RLIM_INFINITY))

    return subprocess.run([PY, "-m", "wdendrite.cli", *map(str, args)], cwd=cwd, capture_output=True, text=True,
                          timeout=300, preexec_fn=limited)


def test_out_of_memory_under_an_address_space_limit_is_one_line_and_exit_2(tmp_path, no_address_limit):
    # what Warp and a small run take (measured here: Warp reserves a few hundred MB of addresses),
    # plus 256 MiB: a small run fits, a 4096^2 lattice (about 0.4 GiB for its search alone) does not
    code = ("import sys; from wdendrite import cli; code = cli.main(sys.argv[1:]); "
            "print([l for l in open('/proc/self/status') if l.startswith('VmPeak:')][0].split()[1])")
    small = ["lightning", "--size", 32, "-o", "s.png", "--quiet"]
    peak = subprocess.run([PY, "-c", code, *map(str, small)], cwd=tmp_path, capture_output=True, text=True, check=True)
    limit = int(peak.stdout.split()[-1]) * 1024 + 2**28
    p = _under_address_limit([*small, "--force"], limit, tmp_path)
    assert p.returncode == 0, p.stderr
    p = _under_address_limit(["lightning", "--size", 4096, "-o", "l.png", "--quiet"], limit, tmp_path)
    lines = [line for line in p.stderr.splitlines() if line.startswith("wdendrite:")]
    assert p.returncode == 2 and len(lines) == 1 and "Traceback" not in p.stderr, p.stderr
    assert lines[0].startswith("wdendrite: error: not enough memory: ") and "of shape (4096, 4096) needs about " \
        in lines[0] and "under the address-space limit of " in lines[0] and "(ulimit -v)" in lines[0]
    assert not (tmp_path / "l.png").exists()


@pytest.mark.parametrize("error", [RuntimeError("Failed to allocate 67108864 bytes on device 'cpu'"),
                                   OSError(errno.ENOMEM, "Cannot allocate memory")])
def test_an_allocation_failing_beyond_the_checks_is_not_enough_memory(error, tmp_path, monkeypatch, capsys):
    from wdendrite import batch
    from wdendrite._spec import all_presets

    def fails(**kwargs):
        raise error

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(all_presets()["costs"], "func", fails)
    assert cli.main(["costs", "--size", "16", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"wdendrite: error: not enough memory: {error.strerror if isinstance(error, OSError) else error}"
    failed = []
    batch._attempt(lambda: fails(), batch.Task("t", "costs", {}, ["t.png"]), failed)
    assert isinstance(failed[0][1], MemoryError)  # (a batch counts it as memory the machine lacks: exit 2)
    assert _checks.memory_error(RuntimeError("something else")) is None
