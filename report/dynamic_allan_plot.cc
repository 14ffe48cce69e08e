#include "report/dynamic_allan_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "analyze/allan/units.h"
#include "analyze/judge/plan.h"
#include "common/strings.h"
#include "report/run_samples.h"
#include "report/svg_plot.h"

namespace imuqual::report {
namespace {

// "12:30" (minutes and seconds), "1:02:30" past an hour, "0:12.5" when the
// seconds are not whole.
std::string Clock(double s) {
  char buf[40];
  if (std::fabs(s - std::round(s)) > 1e-6 && s < 3600) {
    const long minutes = static_cast<long>(s / 60);
    std::snprintf(buf, sizeof buf, "%ld:%04.1f", minutes, s - 60.0 * static_cast<double>(minutes));
    return buf;
  }
  const long total = std::lround(s);
  if (total >= 3600) {
    std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", total / 3600, total / 60 % 60, total % 60);
  } else {
    std::snprintf(buf, sizeof buf, "%ld:%02ld", total / 60, total % 60);
  }
  return buf;
}

// Early (0) blue to late (1) red through violet and magenta: HSL hue 220 ->
// 360 degrees, saturation 0.75, lightness 0.45.
std::string RampColor(double f) {
  const double h = std::fmod(220.0 + 140.0 * f, 360.0) / 60.0, s = 0.75, l = 0.45;
  const double c = (1 - std::fabs(2 * l - 1)) * s;
  const double x = c * (1 - std::fabs(std::fmod(h, 2.0) - 1));
  const int sector = static_cast<int>(h);
  const double rgb[6][3] = {{c, x, 0}, {x, c, 0}, {0, c, x}, {0, x, c}, {x, 0, c}, {c, 0, x}};
  const double* v = rgb[std::clamp(sector, 0, 5)];
  const double m = l - c / 2;
  char buf[8];
  std::snprintf(buf, sizeof buf, "#%02x%02x%02x", static_cast<int>(std::lround((v[0] + m) * 255)),
                static_cast<int>(std::lround((v[1] + m) * 255)),
                static_cast<int>(std::lround((v[2] + m) * 255)));
  return buf;
}

}  // namespace

std::string DynamicAllanSvg(const allan::DynamicAllan& davar, const DynamicAllanPlotStyle& style) {
  LogLogPlot plot;
  plot.title = style.title;
  plot.y_scale = style.y_scale;
  plot.y_label = style.y_label;
  plot.y2_label = style.y2_label;
  // The windows with a curve (a window inside a gap has none).
  std::vector<const allan::DynamicAllanWindow*> drawn;
  for (const allan::DynamicAllanWindow& w : davar.windows) {
    if (!w.curve.points.empty()) drawn.push_back(&w);
  }
  const size_t n = drawn.size();
  for (size_t i = 0; i < n; ++i) {
    const allan::DynamicAllanWindow& w = *drawn[i];
    PlotSeries s;
    const std::string span = Clock(w.start_s) + "-" + Clock(w.start_s + w.length_s);
    s.label = "window " + span;
    s.color = RampColor(n > 1 ? static_cast<double>(i) / static_cast<double>(n - 1) : 0.0);
    s.markers = false;
    s.stroke_width = 1.4;
    s.opacity = 0.85;
    s.in_legend = i == 0 || i + 1 == n;
    for (const allan::CurvePoint& p : w.curve.points) {
      s.x.push_back(p.tau_s);
      s.y.push_back(p.dev);
    }
    char tip[160];
    std::snprintf(tip, sizeof tip, "window %s (%lld valid samples)", span.c_str(),
                  static_cast<long long>(w.valid_samples));
    s.tooltip = tip;
    plot.series.push_back(std::move(s));
  }
  plot.notes.push_back(std::to_string(n) + " windows of " + Clock(davar.window_s) + " every " +
                       Clock(davar.step_s) + ", early blue to late red; each the");
  plot.notes.push_back("OADEV of its own samples. Curves that stand apart: a");
  plot.notes.push_back("non-stationary stretch (step, ramp, burst).");
  if (const std::optional<allan::LevelChange> c = allan::ShortTauLevelChange(davar)) {
    char line[160];
    std::snprintf(line, sizeof line, "At tau %s s, last window / first: %.4f +- %.4f",
                  ShortestReal(c->tau_s).c_str(), c->ratio, c->sigma);
    plot.notes.push_back(line);
    plot.notes.push_back(std::abs(c->ratio - 1) > 3 * c->sigma
                             ? "(the noise level itself changed)."
                             : "(no change of the noise level seen).");
  }
  if (const size_t empty = davar.windows.size() - n; empty > 0) {
    plot.notes.push_back(std::to_string(empty) + (empty == 1 ? " window" : " windows") +
                         " inside a gap: no curve.");
  }
  return plot.ToSvg();
}

Result<std::vector<std::string>> RunDynamicAllanSvgs(store::Archive& archive,
                                                     const std::string& run_id) {
  auto run = FindRunWithRate(archive, run_id);
  if (!run.ok()) return run.status();
  const store::RunInfo* info = &run->info;
  const double tau0 = 1 / info->nominal_rate_hz;
  pb::TestPlan plan;
  const bool have_plan = plan.ParseFromString(info->plan);
  const double warmup_s = have_plan ? plan.warmup_s() : 0.0;
  const int64_t skip = std::llround(warmup_s * info->nominal_rate_hz);
  constexpr int64_t kMaxSamples = int64_t{1} << 24;
  const size_t axes = info->axes.size();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<std::string> out;
  // One axis at a time: one axis's record in memory (at most 64 MB).
  for (size_t a = 0; a < axes; ++a) {
    const store::AxisInfo& axis = info->axes[a];
    const double out_of_range_at =
        have_plan ? judge::OutOfRangeAt(plan, axis.kind) : std::numeric_limits<double>::infinity();
    std::vector<float> samples;
    Status too_long = Status::Ok();
    auto put = [&](int64_t first, int64_t counter, float v) {
      const int64_t k = counter - first - skip;
      if (k < 0) return;
      if (k >= kMaxSamples) {
        too_long = Status::InvalidArgument(
            "run '" + run_id + "' is too long for its dynamic Allan plot here (more than " +
            std::to_string(kMaxSamples) +
            " samples per axis): export it (--format samples) and use imuqual analyze --davar");
        return;
      }
      if (static_cast<int64_t>(samples.size()) <= k)
        samples.resize(static_cast<size_t>(k) + 1, nan);
      samples[static_cast<size_t>(k)] = v;
    };
    RunSampleVisitor visitor;
    visitor.missing = [&](int64_t first, int64_t from, int64_t count) {
      put(first, from + count - 1, nan);
      return too_long;
    };
    visitor.chunk = [&](int64_t first, const store::ChunkRecord& c, const store::ChunkData& d) {
      for (int i = 0; i < d.num_samples && too_long.ok(); ++i) {
        const float v = d.at(static_cast<int>(a), i);
        put(first, c.first_sample + i, judge::OutOfRange(v, out_of_range_at) ? nan : v);
      }
      for (const store::SampleFlag& f :
           d.flags) {  // saturated or invalid, as the analysis reads them
        if ((f.bits & (1 | 2)) && f.axis == a && too_long.ok()) {
          put(first, c.first_sample + f.sample, nan);
        }
      }
      return too_long;
    };
    auto walk = WalkRunSamples(archive, run->key, *info, visitor);
    if (!walk.ok()) return walk.status();
    if (walk->first < 0) return Status::NotFound("run '" + run_id + "' has no archived sample");
    const bool accel = axis.kind == pb::ACCEL;
    allan::DynamicAllanOptions options;
    options.intervals = false;  // the plot draws the curves alone
    auto davar = allan::ComputeDynamicAllan(std::span<const float>(samples), tau0, {}, options);
    if (!davar.ok()) {
      return Status::InvalidArgument("run '" + run_id + "' axis " + axis.name + ": " +
                                     davar.status().message());
    }
    DynamicAllanPlotStyle style;
    style.title = info->serial + " " + axis.name + " (run " + run_id + "): dynamic Allan deviation";
    style.y_scale = accel ? 1.0 / allan::kMicroGInMetersPerSecSq : 3600.0;
    style.y_label = accel ? "Allan deviation [ug]" : "Allan deviation [deg/h]";
    style.y2_label = accel ? "[m/s^2]" : "[deg/s]";
    out.push_back(DynamicAllanSvg(*davar, style));
  }
  return out;
}

}  // namespace imuqual::report
