// Throughput and state size of the streaming Allan engine (one axis, one
// core): rate samples appended per second with C = 8 points per octave and
// the default 28 levels, in LCM-sized batches (100 samples) and large ones.
//
// Figures: stream_samples_per_s (100-sample batches, gap-free float input),
// stream_large_batch_samples_per_s, stream_gappy_samples_per_s (0.1% invalid
// samples), stream_state_bytes_per_axis.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <iostream>  // bench_summary.h uses std::cerr without including it
#include <random>
#include <span>
#include <vector>

#include "analyze/allan/streaming.h"
#include "bench/bench_summary.h"

namespace {

using imuqual::allan::StreamingAllan;
using imuqual::allan::StreamingOptions;

constexpr size_t kSamples = size_t{1} << 22;

const std::vector<float>& Rate() {
  static const std::vector<float> rate = [] {
    std::mt19937_64 rng(1);
    std::normal_distribution<float> gauss(0.0f, 0.05f);
    std::vector<float> r(kSamples);
    for (float& y : r) y = 0.3f + gauss(rng);
    return r;
  }();
  return rate;
}

const std::vector<uint8_t>& SparseInvalid() {
  static const std::vector<uint8_t> flags = [] {
    std::mt19937_64 rng(2);
    std::vector<uint8_t> f(kSamples, 0);
    for (size_t i = 0; i < kSamples / 1000; ++i) f[rng() % kSamples] = 1;
    return f;
  }();
  return flags;
}

StreamingOptions BenchOptions() {
  StreamingOptions o;
  o.tau0_s = 0.01;
  o.density = 8;
  return o;
}

void BM_StreamAppend(benchmark::State& state, bool gappy) {
  const size_t batch = static_cast<size_t>(state.range(0));
  const std::vector<float>& rate = Rate();
  const std::vector<uint8_t>& flags = SparseInvalid();
  for (auto _ : state) {
    StreamingAllan engine(BenchOptions());
    for (size_t pos = 0; pos < rate.size(); pos += batch) {
      const size_t n = std::min(batch, rate.size() - pos);
      const std::span<const float> y(rate.data() + pos, n);
      if (gappy) {
        engine.Append(y, std::span<const uint8_t>(flags.data() + pos, n));
      } else {
        engine.Append(y);
      }
    }
    benchmark::DoNotOptimize(engine.samples());
    state.counters["state_bytes"] = static_cast<double>(engine.StateBytes());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()) *
                          static_cast<int64_t>(rate.size()));
}

void BM_StreamAppendClean(benchmark::State& state) { BM_StreamAppend(state, false); }
void BM_StreamAppendGappy(benchmark::State& state) { BM_StreamAppend(state, true); }

BENCHMARK(BM_StreamAppendClean)->Arg(100)->Arg(65536)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_StreamAppendGappy)->Arg(100)->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  imuqual::bench::SummaryReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  const double samples = static_cast<double>(kSamples);
  imuqual::bench::PrintFigure("stream_samples_per_s",
                              samples / reporter.BestRealSeconds("BM_StreamAppendClean/100"),
                              "samples/s");
  imuqual::bench::PrintFigure("stream_large_batch_samples_per_s",
                              samples / reporter.BestRealSeconds("BM_StreamAppendClean/65536"),
                              "samples/s");
  imuqual::bench::PrintFigure("stream_gappy_samples_per_s",
                              samples / reporter.BestRealSeconds("BM_StreamAppendGappy/100"),
                              "samples/s");
  imuqual::bench::PrintFigure("stream_state_bytes_per_axis",
                              static_cast<double>(StreamingAllan(BenchOptions()).StateBytes()),
                              "bytes");
  benchmark::Shutdown();
  return 0;
}
