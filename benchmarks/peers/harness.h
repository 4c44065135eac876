// Shared helpers of the peer harnesses (benchmarks/peers/*.cpp): timing one loop iteration at a
// time and printing one JSON object on standard output. Header-only, no dependency beyond the
// C++ standard library, so that any harness built by peers/visp.py (image moments, luminance, ...)
// can include it.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace peer {

using Clock = std::chrono::steady_clock;

// Seconds between two time points.
inline double seconds(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

// The q-quantile (0..1) of a sample, by nearest rank on a sorted copy.
inline double quantile(std::vector<double> x, double q) {
  if (x.empty()) return 0.0;
  std::sort(x.begin(), x.end());
  std::size_t i = static_cast<std::size_t>(q * (x.size() - 1) + 0.5);
  return x[std::min(i, x.size() - 1)];
}

inline double mean(const std::vector<double> &x) {
  double s = 0.0;
  for (double v : x) s += v;
  return x.empty() ? 0.0 : s / x.size();
}

// {"median_us": ..., "mean_us": ..., "p05_us": ..., "p95_us": ..., "n": ...} of per-call seconds.
inline std::string summary_us(const std::vector<double> &s) {
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "{\"median_us\": %.6g, \"mean_us\": %.6g, \"p05_us\": %.6g, \"p95_us\": %.6g, \"n\": %zu}",
                1e6 * quantile(s, 0.5), 1e6 * mean(s), 1e6 * quantile(s, 0.05), 1e6 * quantile(s, 0.95),
                s.size());
  return buf;
}

// A JSON array of doubles printed with 17 significant digits (round-trips a double).
inline std::string array(const std::vector<double> &x) {
  std::string out = "[";
  char buf[40];
  for (std::size_t i = 0; i < x.size(); ++i) {
    std::snprintf(buf, sizeof buf, "%s%.17g", i ? ", " : "", x[i]);
    out += buf;
  }
  return out + "]";
}

// An integer command-line argument (argv[i]) or a default.
inline long arg(int argc, char **argv, int i, long fallback) {
  return argc > i ? std::strtol(argv[i], nullptr, 10) : fallback;
}

}  // namespace peer
