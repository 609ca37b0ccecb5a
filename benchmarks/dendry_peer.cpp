// Times the authors' Dendry (a peer, built by benchmarks/dendry_peer.py) on rows of an image.
//
// Usage: dendry_peer CASE SEED LEVELS WIDTH HEIGHT ROW0 COL0 ROWS COLS STEP [OUT]
//   CASE: table1-elevation, table1-distance (LEVELS 1-5) or lichtenberg-distance (LEVELS 1-6)
// Evaluates ROWS rows of COLS pixels: rows ROW0, ROW0 + STEP, ... from column COL0. Pixel (i, j) of
// a WIDTH x HEIGHT image lies at x = S j / WIDTH, y = S i / HEIGHT over the noise domain
// (0, 0)-(S, S), S = 4, as the peer's own application puts it. Only the evaluation loop is timed.
// Prints one line of key=value pairs (seconds, pixels, finite, min, max, mean of the finite values); OUT, when given, receives the values as raw float32, row by row.
// This file is ours; it calls the peer's public Noise constructor and evaluate functions only.

#include <algorithm>  // (before the peer's headers, which use std::clamp without it)
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "lichtenbergcontrolfunction.h"
#include "noise.h"
#include "perlincontrolfunction.h"

namespace {

constexpr double kSide = 4.0;

template <typename Eval>
std::vector<float> run(Eval eval, int width, int height, int row0, int col0, int rows, int cols, int step,
                       double& seconds) {
    std::vector<float> values(static_cast<size_t>(rows) * cols);
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < rows; ++i) {
        const double y = kSide * (row0 + i * step) / height;
        for (int j = 0; j < cols; ++j) {
            values[static_cast<size_t>(i) * cols + j] = static_cast<float>(eval(kSide * (col0 + j) / width, y));
        }
    }
    seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return values;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 11 || argc > 12) {
        std::fprintf(stderr, "usage: %s CASE SEED LEVELS WIDTH HEIGHT ROW0 COL0 ROWS COLS STEP [OUT]\n", argv[0]);
        return 2;
    }
    const std::string which = argv[1];
    const int seed = std::atoi(argv[2]), levels = std::atoi(argv[3]), width = std::atoi(argv[4]);
    const int height = std::atoi(argv[5]), row0 = std::atoi(argv[6]), col0 = std::atoi(argv[7]);
    const int rows = std::atoi(argv[8]), cols = std::atoi(argv[9]), step = std::atoi(argv[10]);
    const int top = which == "lichtenberg-distance" ? 6 : 5;
    if (levels < 1 || levels > top) {
        std::fprintf(stderr, "LEVELS must lie in 1-%d for %s, got %d\n", top, which.c_str(), levels);
        return 2;
    }
    if (width < 1 || height < 1 || rows < 1 || cols < 1 || step < 1 || row0 < 0 || col0 < 0 ||
        row0 + (rows - 1) * step >= height || col0 + cols > width) {
        std::fprintf(stderr, "%d rows every %d from row %d, %d columns from column %d: not inside a %d x %d image\n",
                     rows, step, row0, cols, col0, width, height);
        return 2;
    }
    const Point2D noise_lo(0.0, 0.0), noise_hi(kSide, kSide);
    double seconds = 0.0;
    std::vector<float> values;
    if (which == "table1-elevation" || which == "table1-distance") {
        // the Dendry paper's Table 1 setup (there at 2 levels), in the peer's own parameters
        const bool elevation = which == "table1-elevation";
        const Noise<PerlinControlFunction> noise(std::make_unique<PerlinControlFunction>(), noise_lo, noise_hi,
                                                 Point2D(-0.2, -0.4), Point2D(1.4, 0.7), seed, 0.25, levels, 0.1, 3,
                                                 0.5, 0.05, elevation, false, false, false, !elevation);
        values = run([&](double x, double y) { return noise.evaluateTerrain(x, y); }, width, height, row0, col0,
                     rows, cols, step, seconds);
    } else if (which == "lichtenberg-distance") {
        // the Lichtenberg figure: distance to the branches (in level-1 cells)
        const Noise<LichtenbergControlFunction> noise(std::make_unique<LichtenbergControlFunction>(), noise_lo,
                                                      noise_hi, Point2D(-1.0, -1.0), Point2D(1.0, 1.0), seed, 0.25,
                                                      levels, 0.05, 3, 1.0, 0.0, false, false, false, false, true);
        values = run([&](double x, double y) { return noise.evaluateLichtenberg(x, y); }, width, height, row0, col0,
                     rows, cols, step, seconds);
    } else {
        std::fprintf(stderr, "unknown case '%s' (table1-elevation, table1-distance, lichtenberg-distance)\n",
                     which.c_str());
        return 2;
    }
    size_t finite = 0;
    double lo = INFINITY, hi = -INFINITY, sum = 0.0;
    for (const float v : values) {
        if (std::isfinite(v)) {
            ++finite;
            lo = std::fmin(lo, v);
            hi = std::fmax(hi, v);
            sum += v;
        }
    }
    if (argc == 12) {
        FILE* out = std::fopen(argv[11], "wb");
        if (out == nullptr || std::fwrite(values.data(), sizeof(float), values.size(), out) != values.size() ||
            std::fclose(out) != 0) {
            std::fprintf(stderr, "cannot write %s\n", argv[11]);
            return 1;
        }
    }
    std::printf("seconds=%.6f pixels=%zu finite=%zu min=%.9g max=%.9g mean=%.9g\n", seconds, values.size(), finite, lo,
                hi, finite ? sum / finite : NAN);
    return 0;
}
