#include "report/time_series.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "analyze/allan/units.h"
#include "analyze/judge/measurements.h"
#include "common/strings.h"
#include "common/text_util.h"
#include "imuqual/plan.pb.h"
#include "report/marks.h"
#include "report/run_samples.h"
#include "report/svg_plot.h"

namespace imuqual::report {

EnvelopeBuilder::EnvelopeBuilder(size_t channels, size_t max_bins)
    : channels_(channels), max_bins_(std::max<size_t>(max_bins, 2)) {}

void EnvelopeBuilder::Halve() {
  std::vector<EnvelopeBin> merged;
  merged.reserve(bins_.size() / 2 + 1);
  for (size_t i = 0; i < bins_.size(); i += 2) {
    EnvelopeBin b = std::move(bins_[i]);
    if (i + 1 < bins_.size()) {
      const EnvelopeBin& o = bins_[i + 1];
      for (size_t c = 0; c < channels_; ++c) {
        if (o.n[c] == 0) continue;
        if (b.n[c] == 0) {
          b.min[c] = o.min[c];
          b.max[c] = o.max[c];
        } else {
          b.min[c] = std::min(b.min[c], o.min[c]);
          b.max[c] = std::max(b.max[c], o.max[c]);
        }
        b.sum[c] += o.sum[c];
        b.n[c] += o.n[c];
      }
    }
    merged.push_back(std::move(b));
  }
  bins_ = std::move(merged);
  width_ *= 2;
}

void EnvelopeBuilder::Add(int64_t counter, std::span<const double> values) {
  if (!started_) {
    first_ = counter;
    started_ = true;
  }
  if (counter < first_) return;  // counters do not go back (the walk guarantees it)
  size_t index = static_cast<size_t>((counter - first_) / width_);
  while (index >= max_bins_) {
    Halve();
    index = static_cast<size_t>((counter - first_) / width_);
  }
  while (bins_.size() <= index) {
    EnvelopeBin b;
    b.first = first_ + static_cast<int64_t>(bins_.size()) * width_;
    b.min.assign(channels_, 0);
    b.max.assign(channels_, 0);
    b.sum.assign(channels_, 0);
    b.n.assign(channels_, 0);
    bins_.push_back(std::move(b));
  }
  EnvelopeBin& b = bins_[index];
  for (size_t c = 0; c < channels_ && c < values.size(); ++c) {
    const double v = values[c];
    if (!std::isfinite(v)) continue;
    if (b.n[c] == 0) {
      b.min[c] = b.max[c] = v;
    } else {
      b.min[c] = std::min(b.min[c], v);
      b.max[c] = std::max(b.max[c], v);
    }
    b.sum[c] += v;
    ++b.n[c];
  }
}

namespace {

std::string Esc(const std::string& s) { return HtmlEscape(s); }
std::string F(double v) { return SvgPx(v); }

std::string G(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", std::abs(v) < 1e-300 ? 0.0 : v);
  return buf;
}

// Tick step for a linear range: 1, 2 or 5 x 10^k, about `count` ticks.
double NiceStep(double range, int count) {
  if (!(range > 0)) return 1;
  const double raw = range / count;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (raw <= m * p) return m * p;
  return 10 * p;
}

}  // namespace

std::string TimeSeriesPlot::ToSvg(const EnvelopeBuilder& builder) const {
  const std::vector<EnvelopeBin>& bins = builder.bins();
  const double rate =
      counters_per_second > 0 && std::isfinite(counters_per_second) ? counters_per_second : 1;
  const double span_s = static_cast<double>(bins.size() * builder.width()) / rate;
  const double time_unit = span_s >= 2 * 3600 ? 3600 : span_s >= 600 ? 60 : 1;
  const char* time_name = time_unit == 3600 ? "h" : time_unit == 60 ? "min" : "s";
  const double x_max = std::isfinite(span_s) ? std::max(span_s / time_unit, 1e-9) : 1.0;

  const int left = 78, right = 16, top = 34, gap = 16;
  const double pw = width - left - right;
  std::vector<const SeriesPanel*> shown;
  for (const SeriesPanel& p : panels)
    if (p.channel < builder.channels()) shown.push_back(&p);
  double plot_bottom = top;
  for (const SeriesPanel* p : shown)
    plot_bottom += (p->envelope ? panel_height : mean_panel_height) + gap;
  const int height = static_cast<int>(plot_bottom) + 34 + static_cast<int>(notes.size()) * 15;
  std::string svg = "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + std::to_string(width) +
                    "\" height=\"" + std::to_string(height) + "\" viewBox=\"0 0 " +
                    std::to_string(width) + " " + std::to_string(height) +
                    "\" font-family=\"sans-serif\" font-size=\"12\" role=\"img\">\n";
  svg += "<title>" + Esc(title) + "</title>\n";
  svg += "<rect width=\"100%\" height=\"100%\" fill=\"#ffffff\"/>\n";
  svg += "<text x=\"" + F(left + pw / 2) + "\" y=\"22\" text-anchor=\"middle\" font-size=\"15\">" +
         Esc(title) + "</text>\n";
  const double half = static_cast<double>(builder.width()) / 2;
  const auto px = [&](const EnvelopeBin& b) {
    const double t = (static_cast<double>(b.first - builder.first()) + half) / rate / time_unit;
    return left + std::clamp(t / x_max, 0.0, 1.0) * pw;
  };
  const double x_step = NiceStep(x_max, 6);

  double ptop = top;
  for (const SeriesPanel* panel : shown) {
    const size_t c = panel->channel;
    const double ph = panel->envelope ? panel_height : mean_panel_height;
    const auto map = [&](double v) { return (v - panel->offset) * panel->scale; };
    const auto mean = [&](const EnvelopeBin& b) {
      return map(b.sum[c] / static_cast<double>(b.n[c]));
    };
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const EnvelopeBin& b : bins) {
      if (b.n[c] == 0) continue;
      const double l = panel->envelope ? map(b.min[c]) : mean(b);
      const double h = panel->envelope ? map(b.max[c]) : mean(b);
      lo = std::min({lo, l, h});
      hi = std::max({hi, l, h});
    }
    if (shaded_s > 0 && std::isfinite(shaded_s)) {
      // The warm-up: recorded, not analysed.
      const double w = std::clamp(shaded_s / time_unit / x_max, 0.0, 1.0) * pw;
      svg += "<rect class=\"warmup\" x=\"" + F(left) + "\" y=\"" + F(ptop) + "\" width=\"" + F(w) +
             "\" height=\"" + F(ph) + "\" fill=\"#e8e8e8\"/>\n";
      if (panel == shown.front()) {
        svg += "<text x=\"" + F(left + 4) + "\" y=\"" + F(ptop + 12) +
               "\" font-size=\"10\" fill=\"#555555\">" + Esc(shaded_label) + "</text>\n";
      }
    }
    // The stationarity scan's events on this channel: a burst's stretch
    // shaded, a step's time a dashed line; labelled in the channel's first
    // panel.
    // A time, s from the first sample, as x in the panel.
    const auto ex = [&](double t_s) {
      return left + std::clamp(t_s / time_unit / x_max, 0.0, 1.0) * pw;
    };
    int labelled = 0;
    for (const EventMark& e : events) {
      if (e.channel != c || !std::isfinite(e.start_s)) continue;
      const double x0 = ex(e.start_s);
      if (e.end_s > e.start_s) {
        svg += "<rect class=\"event\" x=\"" + F(x0) + "\" y=\"" + F(ptop) + "\" width=\"" +
               F(std::max(ex(e.end_s) - x0, 1.0)) + "\" height=\"" + F(ph) +
               "\" fill=\"#ff7f0e\" fill-opacity=\"0.25\"><title>" + Esc(e.label) +
               "</title></rect>\n";
      } else {
        svg += "<line class=\"event\" x1=\"" + F(x0) + "\" y1=\"" + F(ptop) + "\" x2=\"" + F(x0) +
               "\" y2=\"" + F(ptop + ph) +
               "\" stroke=\"#d62728\" stroke-width=\"1.5\" stroke-dasharray=\"5,3\"><title>" +
               Esc(e.label) + "</title></line>\n";
      }
      // Below the warm-up's name, as many as the panel has room for.
      if (panel->envelope && 24 + 12 * labelled <= ph - 4) {
        const bool right_side = x0 > left + 0.6 * pw;
        svg += "<text x=\"" + F(right_side ? x0 - 3 : x0 + 3) + "\" y=\"" +
               F(ptop + 24 + 12 * labelled) + "\" font-size=\"10\" fill=\"#d62728\"" +
               (right_side ? " text-anchor=\"end\"" : "") + ">" + Esc(e.label) + "</text>\n";
        ++labelled;
      }
    }
    for (const JudgedStretch& j : judged) {
      if (j.channel != c) continue;
      svg += "<rect class=\"judged\" x=\"" + F(ex(j.start_s)) + "\" y=\"" + F(ptop + ph - 5) +
             "\" width=\"" + F(std::max(ex(j.end_s) - ex(j.start_s), 1.0)) +
             "\" height=\"5\" fill=\"#2ca02c\"><title>" + Esc(j.label) + "</title></rect>\n";
    }
    svg += "<rect x=\"" + F(left) + "\" y=\"" + F(ptop) + "\" width=\"" + F(pw) + "\" height=\"" +
           F(ph) + "\" fill=\"none\" stroke=\"#888888\"/>\n";
    svg += "<text transform=\"translate(16," + F(ptop + ph / 2) +
           ") rotate(-90)\" text-anchor=\"middle\" font-size=\"11\">" + Esc(panel->label) +
           "</text>\n";
    // Vertical grid at the time ticks.
    for (double t = 0; t <= x_max * (1 + 1e-9) && t <= 50 * x_step; t += x_step) {
      const double x = left + t / x_max * pw;
      svg += "<line x1=\"" + F(x) + "\" y1=\"" + F(ptop) + "\" x2=\"" + F(x) + "\" y2=\"" +
             F(ptop + ph) + "\" stroke=\"#eeeeee\"/>\n";
    }
    if (!std::isfinite(lo)) {
      svg += "<text x=\"" + F(left + pw / 2) + "\" y=\"" + F(ptop + ph / 2) +
             "\" text-anchor=\"middle\" fill=\"#555555\">no value</text>\n";
      ptop += ph + gap;
      continue;
    }
    // A constant (up to rounding, also on a drift panel's scaled values):
    // a visible range around it (a drift panel's rounding residue is 0).
    const double scale_floor =
        panel->envelope ? 0.0 : 1e-9 * std::abs(panel->offset * panel->scale);
    if (hi - lo <= std::max(std::max(std::abs(hi), std::abs(lo)) * 1e-12, scale_floor)) {
      double center = 0.5 * (hi + lo);
      if (std::abs(center) <= scale_floor) center = 0;
      const double pad = std::max(std::abs(center) * 0.01, center == 0 ? 1.0 : 0.0);
      lo = center - pad;
      hi = center + pad;
    }
    const double margin = 0.06 * (hi - lo);
    lo -= margin;
    hi += margin;
    const auto py = [&](double v) { return ptop + (hi - v) / (hi - lo) * ph; };
    const double y_step = NiceStep(hi - lo, 4);
    int y_ticks = 0;
    for (double v = std::ceil(lo / y_step) * y_step; v <= hi && y_ticks < 50;
         v += y_step, ++y_ticks) {
      svg += "<line x1=\"" + F(left - 4) + "\" y1=\"" + F(py(v)) + "\" x2=\"" + F(left + pw) +
             "\" y2=\"" + F(py(v)) + "\" stroke=\"#eeeeee\"/>\n";
      svg += "<text x=\"" + F(left - 7) + "\" y=\"" + F(py(v) + 4) + "\" text-anchor=\"end\">" +
             G(v) + "</text>\n";
    }
    // Contiguous stretches of bins with values: the band, then the mean.
    const std::string& color = panel->color;
    size_t i = 0;
    while (i < bins.size()) {
      if (bins[i].n[c] == 0) {
        ++i;
        continue;
      }
      size_t j = i;
      while (j < bins.size() && bins[j].n[c] > 0) ++j;
      std::string upper, lower, line;
      for (size_t k = i; k < j; ++k) {
        upper += F(px(bins[k])) + "," + F(py(map(bins[k].max[c]))) + " ";
        line += F(px(bins[k])) + "," + F(py(mean(bins[k]))) + " ";
      }
      for (size_t k = j; k-- > i;) lower += F(px(bins[k])) + "," + F(py(map(bins[k].min[c]))) + " ";
      if (panel->envelope && j - i == 1) {  // one bin alone: its range as a bar
        svg += "<line x1=\"" + F(px(bins[i])) + "\" y1=\"" + F(py(map(bins[i].max[c]))) +
               "\" x2=\"" + F(px(bins[i])) + "\" y2=\"" + F(py(map(bins[i].min[c]))) +
               "\" stroke=\"" + color + "\" stroke-opacity=\"0.35\" stroke-width=\"3\"/>\n";
      } else if (panel->envelope) {
        svg += "<polygon points=\"" + upper + lower + "\" fill=\"" + color +
               "\" fill-opacity=\"0.22\" stroke=\"none\"/>\n";
      }
      if (j - i == 1) {
        svg += "<circle cx=\"" + F(px(bins[i])) + "\" cy=\"" + F(py(mean(bins[i]))) +
               "\" r=\"1.6\" fill=\"" + color + "\"/>\n";
      } else {
        svg += "<polyline points=\"" + line + "\" fill=\"none\" stroke=\"" + color +
               "\" stroke-width=\"1.4\"/>\n";
      }
      i = j;
    }
    ptop += ph + gap;
  }
  const double axis_y = plot_bottom - gap;
  for (double t = 0; t <= x_max * (1 + 1e-9) && t <= 50 * x_step; t += x_step) {
    svg += "<text x=\"" + F(left + t / x_max * pw) + "\" y=\"" + F(axis_y + 16) +
           "\" text-anchor=\"middle\">" + G(t) + "</text>\n";
  }
  svg += "<text x=\"" + F(left + pw / 2) + "\" y=\"" + F(axis_y + 32) +
         "\" text-anchor=\"middle\">device time [" + time_name + "]</text>\n";
  double ny = axis_y + 50;
  for (const std::string& note : notes) {
    svg += "<text x=\"" + F(left) + "\" y=\"" + F(ny) + "\" font-size=\"10.5\" fill=\"#555555\">" +
           Esc(note) + "</text>\n";
    ny += 15;
  }
  svg += "</svg>\n";
  return svg;
}

Result<std::string> RunTimeSeriesSvg(store::Archive& archive, const std::string& run_id) {
  auto run = FindRunWithRate(archive, run_id);
  if (!run.ok()) return run.status();
  const store::RunInfo* info = &run->info;
  const size_t axes = info->axes.size();
  constexpr size_t kMaxBins = 600;
  EnvelopeBuilder builder(axes + 1, kMaxBins);  // the axes, then the temperature
  std::vector<double> values(axes + 1);
  bool any_temperature = false;
  int64_t missing = 0, samples = 0;
  RunSampleVisitor visitor;
  visitor.missing = [&](int64_t, int64_t, int64_t count) {
    missing += count;
    return Status::Ok();
  };
  visitor.chunk = [&](int64_t, const store::ChunkRecord& c, const store::ChunkData& d) {
    values[axes] = c.temperature_c ? *c.temperature_c : std::numeric_limits<double>::quiet_NaN();
    any_temperature = any_temperature || c.temperature_c.has_value();
    for (int i = 0; i < d.num_samples; ++i) {
      for (size_t a = 0; a < axes; ++a) values[a] = d.at(static_cast<int>(a), i);
      builder.Add(c.first_sample + i, values);
    }
    samples += d.num_samples;
    return Status::Ok();
  };
  auto walk = WalkRunSamples(archive, run->key, *info, visitor);
  if (!walk.ok()) return walk.status();
  if (samples == 0) return Status::NotFound("run '" + run_id + "' has no archived sample");
  TimeSeriesPlot plot;
  plot.title = info->serial + " (run " + run_id + "): raw samples against time";
  plot.counters_per_second = info->nominal_rate_hz;
  if (pb::TestPlan run_plan; run_plan.ParseFromString(info->plan) && run_plan.warmup_s() > 0) {
    plot.shaded_s = run_plan.warmup_s();
    plot.shaded_label = "warm-up " + ShortestReal(run_plan.warmup_s()) + " s (not analysed)";
  }
  // The run's mean per channel, for the drift panels.
  std::vector<double> sum(axes + 1, 0.0);
  std::vector<int64_t> n(axes + 1, 0);
  for (const EnvelopeBin& b : builder.bins()) {
    for (size_t c = 0; c <= axes; ++c) {
      sum[c] += b.sum[c];
      n[c] += b.n[c];
    }
  }
  for (size_t a = 0; a < axes; ++a) {
    const store::AxisInfo& axis = info->axes[a];
    const bool accel = axis.kind == pb::ACCEL;
    const double run_mean = n[a] > 0 ? sum[a] / static_cast<double>(n[a]) : 0;
    plot.panels.push_back({axis.name + (accel ? " [m/s^2]" : " [deg/s]"), PaletteColor(a), a});
    plot.panels.push_back({axis.name + (accel ? " drift [ug]" : " drift [deg/h]"), PaletteColor(a),
                           a, false, run_mean,
                           accel ? 1.0 / allan::kMicroGInMetersPerSecSq : 3600.0});
  }
  if (any_temperature) plot.panels.push_back({"temperature [deg C]", "#d62728", axes});
  // The stationarity scan's events (times from the end of the warm-up).
  auto result = archive.LoadResult(run->key);
  if (!result.ok()) {
    plot.notes.push_back("Stationarity events not marked: the run's result could not be read (" +
                         result.status().message() + ").");
  } else if (*result) {
    const double warmup = plot.shaded_s;
    int marked = 0;
    for (size_t a = 0; a < axes; ++a) {
      const std::string& axis = info->axes[a].name;
      const auto find = [&](const std::string& name) -> const pb::Measurement* {
        for (const pb::Measurement& m : (*result)->measurements) {
          if (m.axis() == axis && m.name() == name) return &m;
        }
        return nullptr;
      };
      for (int k = 1;; ++k) {
        const std::string name = std::string(judge::kEventPrefix) + std::to_string(k);
        const pb::Measurement* size = find(name);
        const pb::Measurement* time = find(name + "_time");
        if (size == nullptr || time == nullptr) break;
        const pb::Measurement* end = find(name + "_end");
        EventMark mark;
        mark.channel = a;
        mark.start_s = warmup + time->value();
        mark.end_s = end != nullptr ? warmup + end->value() : mark.start_s;
        const std::string value =
            MarkedValue(size->value(), pb::MEASURED,
                        size->has_uncertainty() ? size->uncertainty() : allan::kNaN, 3, true);
        mark.label =
            size->unit() == judge::kNoiseLevelRatioUnit
                ? axis + " noise level x" + value
                : axis + " " + (end != nullptr ? "burst " : "step ") + value + " " + size->unit();
        plot.events.push_back(std::move(mark));
        ++marked;
      }
      // The stretch the axis was judged on, when it is not the whole record.
      const pb::Measurement* judged = find(std::string(judge::kJudgedSegment));
      const pb::Measurement* from = find(std::string(judge::kJudgedSegmentStart));
      const pb::Measurement* to = find(std::string(judge::kJudgedSegmentEnd));
      if (judged != nullptr && from != nullptr && to != nullptr && judged->value() > 0 &&
          !judge::JudgedWholeRecord(*judged)) {
        plot.judged.push_back({a, warmup + from->value(), warmup + to->value(),
                               axis + " judged on " + judge::JudgedStretchText(*judged)});
      }
    }
    if (!plot.judged.empty()) {
      plot.notes.push_back(
          "Green bar: the stretch an axis was judged on (the plan judges each axis's longest "
          "stretch without a found event).");
    }
    if (marked > 0) {
      plot.notes.push_back(
          "Marked: " + std::to_string(marked) + (marked == 1 ? " event" : " events") +
          " of the stationarity scan (dashed: level step or noise level change; shaded: "
          "burst).");
    }
  }
  const double bin_s = static_cast<double>(builder.width()) / info->nominal_rate_hz;
  plot.notes.push_back("Each point is a bin of " + std::to_string(builder.width()) + " samples (" +
                       ShortestReal(bin_s) +
                       " s): line = bin mean, band = bin min..max; breaks where no sample.");
  plot.notes.push_back("Drift: the bin mean less the run's mean, in datasheet units.");
  std::string counts = std::to_string(samples) + " samples";
  if (missing > 0) counts += ", " + std::to_string(missing) + " missing";
  if (walk->skipped > 0)
    counts += ", " + std::to_string(walk->skipped) + (walk->skipped == 1 ? " chunk" : " chunks") +
              " left out as the analysis rejects " + (walk->skipped == 1 ? "it" : "them");
  if (!any_temperature) counts += "; the unit reported no temperature";
  plot.notes.push_back(counts + ".");
  return plot.ToSvg(builder);
}

}  // namespace imuqual::report
