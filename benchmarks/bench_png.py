"""16-bit colour PNGs: file size and time of wdendrite's writer against the same samples unfiltered.

``wd.io.save_png(..., bits=16)`` encodes 16-bit colour itself (Pillow has no such mode): each
row takes the PNG filter whose bytes, read as signed, sum to the least magnitude, then zlib
compresses the rows. The baseline writes the same samples with filter type 0 on every row (what
the writer did before, and what an encoder without filtering does). Images, ``--size`` square:

- ``ramp``: three linear ramps (the smoothest picture there is);
- ``smooth noise``: Gaussian-blurred white noise (sigma ``size / 40``) through three curves;
- ``terrain``: a Dendry terrain (the Table 1 setup, 3 levels) in ``render.relief``'s shaded
  colours, a picture the project makes.

Each way runs ``--repeat`` times (default 5) in turns; sizes in MB, seconds as median (range).

Usage: python benchmarks/bench_png.py [--size 1024] [--repeat 5] [--quick]
"""

from __future__ import annotations

import argparse
import logging
import os
import tempfile

import numpy as np
import warp as wp
from scipy import ndimage

from _measure import cpu_model, interleaved, now, shown

import wdendrite as wd
from wdendrite import io as wio

WAYS = {"unfiltered, zlib 6": dict(filtered=False, level=6), "filtered, zlib 1": dict(level=1),
        "filtered, zlib 3 (the writer)": dict(level=3), "filtered, zlib 6": dict(level=6)}


def images(n: int) -> dict:
    y, x = np.mgrid[0:n, 0:n] / (n - 1.0)
    noise = ndimage.gaussian_filter(np.random.default_rng(0).random((n, n)), n / 40)
    noise = (noise - noise.min()) / (noise.max() - noise.min())
    params = wd.DendryParams(levels=3, eps=0.25, delta=0.1, beta=0.5, noise=0.05, seed=0)
    z = wd.dendry((n, n), domain=((0, 0), (4, 4)), params=params, output="elevation",
                  control=wd.control.perlin(seed=0, domain=((-0.2, -0.4), (1.4, 0.7))))
    return {"ramp": np.stack([x, y, 0.5 * (x + y)], axis=-1),
            "smooth noise": np.stack([noise, noise ** 2, 1.0 - noise], axis=-1),
            "terrain": wd.render.relief(z, 4.0 / n)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--repeat", type=int, default=5, help="runs of each way, in turns (default 5)")
    ap.add_argument("--quick", action="store_true", help="256^2, a smoke test")
    args = ap.parse_args()
    if args.repeat < 1 or args.size < 2:
        ap.error(f"--repeat must be at least 1 and --size at least 2, got {args.repeat} and {args.size}")
    size = 256 if args.quick else args.size
    wp.config.log_level = logging.WARNING  # no start-up banner
    wp.init()
    print(f"# bench_png  {now()}  {cpu_model()}  {size}^2 16-bit RGB; seconds: median (range) of {args.repeat} "
          "runs per way, in turns")
    print("| image | way | MB | seconds |")
    print("| --- | --- | ---: | ---: |")
    with tempfile.TemporaryDirectory() as tmp:
        for name, img in images(size).items():
            data = wio._quantized(img, 16)  # (the same samples for every way)
            paths = {way: os.path.join(tmp, f"{i}.png") for i, way in enumerate(WAYS)}
            runs = interleaved({way: (lambda way=way: wio._png16_rgb(paths[way], data, **WAYS[way])) for way in WAYS},
                               args.repeat)
            for way in WAYS:
                print(f"| {name} | {way} | {os.path.getsize(paths[way]) / 1e6:.2f} | {shown(runs[way][0])} |",
                      flush=True)


if __name__ == "__main__":
    main()
