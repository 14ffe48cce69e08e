#include "cli/plot_command.h"

#include <algorithm>
#include <cstdio>
#include <set>
#include <string>
#include <vector>

#include "common/exit_codes.h"
#include "common/log.h"
#include "common/text_util.h"
#include "report/allan_plots.h"
#include "report/time_series.h"
#include "store/archive.h"
#include "store/query.h"

namespace imuqual::cli {
using report::AllanPlot;
using report::AxisPlotData;
using report::LoadRunPlotData;
using report::LotAllanPlots;
using report::RunAllanPlots;
using report::RunPlotData;
using report::RunTimeSeriesSvg;

namespace {

std::string Sanitize(const std::string& key) {
  std::string out;
  for (char c : key) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '-' || c == '_' || c == '.';
    out += ok ? c : '_';
  }
  return out.empty() ? "_" : out;
}

// out.svg + "x" -> out-x.svg (the extension kept, if any).
std::string DerivedPath(const std::string& path, const std::string& key) {
  const size_t slash = path.find_last_of('/');
  const size_t dot = path.find_last_of('.');
  const bool has_ext = dot != std::string::npos && (slash == std::string::npos || dot > slash + 1);
  std::string out = has_ext ? path.substr(0, dot) : path;
  out += "-";
  out += Sanitize(key);
  if (has_ext) out += path.substr(dot);
  return out;
}

std::string JoinAxes(const std::vector<AxisPlotData>& axes) {
  std::string out;
  for (const AxisPlotData& a : axes) {
    if (!out.empty()) out += ", ";
    out += a.axis;
  }
  return out;
}

}  // namespace

int PlotCommand(const PlotOptions& options) {
  if (options.run_id.empty() == options.lot.empty()) {
    LogError("plot: give exactly one of --run RUN_ID and --lot LOT");
    return kExitUsage;
  }
  if (options.output.empty()) {
    LogError("plot: -o FILE.svg is required");
    return kExitUsage;
  }
  if (options.series && (options.run_id.empty() || !options.axis.empty())) {
    LogError("plot: --series plots one run's raw samples: give --run RUN_ID and no --axis");
    return kExitUsage;
  }
  auto archive = store::Archive::Open(options.db_path, store::Archive::Mode::kRead);
  if (!archive.ok()) {
    LogError(archive.status().message());
    return ExitCodeOf(archive.status());
  }
  std::vector<AllanPlot> plots;
  if (options.series) {
    auto svg = RunTimeSeriesSvg(**archive, options.run_id);
    if (!svg.ok()) {
      LogError(svg.status().message());
      return kExitError;
    }
    plots.push_back({"series", "raw samples", std::move(*svg)});
  } else if (!options.run_id.empty()) {
    auto run = LoadRunPlotData(**archive, options.run_id);
    if (!run.ok()) {
      LogError(run.status().message());
      return kExitError;
    }
    plots = RunAllanPlots(*run, options.axis);
    if (plots.empty() && !options.axis.empty()) {
      LogError("run '" + options.run_id + "' has no axis '" + options.axis +
               "' (its axes: " + JoinAxes(run->axes) + ")");
      return kExitError;
    }
    const bool any_curve = std::any_of(run->axes.begin(), run->axes.end(), [&](const auto& a) {
      return a.curve && (options.axis.empty() || a.axis == options.axis);
    });
    if (plots.empty() || !any_curve) {
      LogError("run '" + options.run_id + "' has no stored Allan curve (state " + run->info.state +
               ")");
      return kExitError;
    }
  } else {
    store::AxisRowFilter filter;
    filter.lot = options.lot;
    auto rows = store::QueryAxisRows(**archive, filter);
    if (!rows.ok()) {
      LogError(rows.status().message());
      return kExitError;
    }
    if (rows->empty()) {
      LogError("no lot '" + options.lot + "' in " + options.db_path + " (imuqual lots lists them)");
      return kExitError;
    }
    std::vector<RunPlotData> runs;
    std::set<std::string> axes_seen;
    std::string axes;
    for (const store::AxisRow& r : *rows) {
      if (axes_seen.insert(r.axis).second) {
        if (!axes.empty()) axes += ", ";
        axes += r.axis;
      }
      if (!runs.empty() && runs.back().info.run_id == r.run_id) continue;
      auto run = LoadRunPlotData(**archive, r.run_id);
      if (!run.ok()) {
        LogError(run.status().message());
        return kExitError;
      }
      runs.push_back(std::move(*run));
    }
    plots = LotAllanPlots(options.lot, runs, options.axis);
    if (plots.empty()) {
      LogError("lot '" + options.lot + "' has no axis '" + options.axis + "' (its axes: " + axes +
               ")");
      return kExitError;
    }
  }
  if (options.output == "-") {  // standard output: one plot only
    if (plots.size() != 1) {
      LogError("plot: -o - writes one plot to standard output; this gives " +
               std::to_string(plots.size()) +
               " (one per axis kind or axis): give --axis, or -o FILE.svg");
      return kExitUsage;
    }
    const std::string& svg = plots.front().svg;
    return std::fwrite(svg.data(), 1, svg.size(), stdout) == svg.size() && std::fflush(stdout) == 0
               ? 0
               : kExitError;
  }
  for (const AllanPlot& plot : plots) {
    const std::string path =
        plots.size() == 1 ? options.output : DerivedPath(options.output, plot.key);
    const Status st = WriteStringToFile(path, plot.svg);
    if (!st.ok()) {
      LogError(st.message());
      return kExitError;
    }
    std::printf("%s\n", path.c_str());
  }
  return 0;
}

}  // namespace imuqual::cli
