#pragma once

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "tests/server/web_client.h"

// Latency of GET requests to the web API on loopback, for the web benches
// (web_bench, web_cohort_bench; docs/server.md): each request on a new
// connection, one at a time, `requests` of them over `targets` in turn.
namespace ves::bench {

struct LatencyStats {
  double p50_ms, p99_ms, max_ms;
};

// Exits 1 naming the target when one does not answer 200.
inline LatencyStats MeasureGets(const std::vector<std::string>& targets, int port,
                                const std::string& token, int requests) {
  using Clock = std::chrono::steady_clock;
  std::vector<double> ms;
  for (int i = 0; i < requests; ++i) {
    const std::string& target = targets[i % targets.size()];
    const auto start = Clock::now();
    const auto r =
        ves::server::testing::HttpCall(port, "GET", target, {{"Authorization", "Bearer " + token}});
    ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
    if (r.status != 200) {
      std::fprintf(stderr, "bench: %s answered %d: %s\n", target.c_str(), r.status,
                   r.body.c_str());
      std::exit(1);
    }
  }
  std::sort(ms.begin(), ms.end());
  return {ms[ms.size() / 2], ms[std::min(ms.size() - 1, ms.size() * 99 / 100)], ms.back()};
}

}  // namespace ves::bench
