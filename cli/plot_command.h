// `imuqual plot`: Allan deviation plots (report/allan_plots.h) or a run's
// time-series plot (report/time_series.h) from the archive, as SVG files.
#ifndef IMUQUAL_CLI_PLOT_COMMAND_H_
#define IMUQUAL_CLI_PLOT_COMMAND_H_

#include <string>

namespace imuqual::cli {

// Command-line fields of `imuqual plot`.
struct PlotOptions {
  std::string db_path;  // --db: the archive (required)
  std::string run_id;   // --run: plot this run (exactly one of run_id and lot)
  std::string lot;      // --lot: overlay every unit of this lot (each unit's latest run)
  std::string axis;     // --axis: only this axis name ("" = every axis)
  bool series = false;  // --series: the run's time-series plot (time_series.h), one SVG
  std::string output;   // -o: the SVG file to write (required); see PlotCommand for
                        // the names used when the selection needs several plots
};

// What it writes (report/allan_plots.h). Run plot: the run's axes of one kind overlaid on one plot
// (each axis its colour, its band, its model and its minimum); a run with gyro and accelerometer
// axes gets one plot per kind. Lot plot: one plot per axis name, every unit's curve; units whose
// axis is judged FAIL, INCONCLUSIVE or MARGINAL are drawn bold, each in its own shade of its
// verdict's colour (reds, violets, ambers), with their band, and listed in the legend with their
// verdict; every curve names its unit, verdict and minimum on hover (an SVG <title>); the others
// are thin and blue. One plot is written to `output` as given; several go to <stem>-<kind or
// axis><ext> beside it (out.svg -> out-x.svg, out-y.svg, ...). Prints the paths written, one per
// line. Returns 0, 1 on an error (unknown run, lot or axis, unreadable archive, unwritable file:
// one line on stderr), 2 on a usage error.
int PlotCommand(const PlotOptions& options);

}  // namespace imuqual::cli

#endif  // IMUQUAL_CLI_PLOT_COMMAND_H_
