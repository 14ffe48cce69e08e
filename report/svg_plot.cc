#include "report/svg_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "common/text_util.h"

namespace imuqual::report {
namespace {

std::string Esc(const std::string& s) { return HtmlEscape(s); }
std::string F(double v) { return SvgPx(v); }

std::string Tick(double decade) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", std::pow(10.0, decade));
  return buf;
}

struct Segment {
  double ax = 0, ay = 0, bx = 0, by = 0;  // px
};

// Distance in px from (x, y) to a segment (a point when both ends coincide).
double Distance(double x, double y, const Segment& s) {
  const double vx = s.bx - s.ax, vy = s.by - s.ay;
  const double len2 = vx * vx + vy * vy;
  double t = len2 > 0 ? ((x - s.ax) * vx + (y - s.ay) * vy) / len2 : 0;
  t = std::clamp(t, 0.0, 1.0);
  return std::hypot(x - (s.ax + t * vx), y - (s.ay + t * vy));
}

bool Drawable(double x, double y) { return x > 0 && y > 0 && std::isfinite(x) && std::isfinite(y); }

// Text widths in px, generous (DejaVu Sans, the usual sans-serif on Linux).
constexpr double kCharWidthPx = 7.0;       // 12 px
constexpr double kSmallCharWidthPx = 6.1;  // 10.5 px
double TextWidth(const std::string& s, double per_char) {
  size_t chars = 0;  // UTF-8 code points
  for (unsigned char c : s) chars += (c & 0xC0) != 0x80;
  return per_char * static_cast<double>(chars);
}

}  // namespace

std::string SvgPx(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", v);
  return buf;
}

std::string PaletteColor(size_t i) {
  static const char* kColors[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b",
                                  "#e377c2", "#17becf", "#bcbd22", "#7f7f7f", "#d62728"};
  return kColors[i % (sizeof kColors / sizeof kColors[0])];
}

std::string LogLogPlot::ToSvg() const {
  const double k = y_scale > 0 && std::isfinite(y_scale) ? y_scale : 1;
  const double log_k = std::log10(k);
  // Data range in decades (of the displayed values), padded to whole decades.
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  auto take = [&](double x, double y) {
    if (!Drawable(x, y)) return;
    x0 = std::min(x0, std::log10(x));
    x1 = std::max(x1, std::log10(x));
    y0 = std::min(y0, std::log10(y) + log_k);
    y1 = std::max(y1, std::log10(y) + log_k);
  };
  for (const PlotSeries& s : series) {
    if (!s.sets_range) continue;
    for (size_t i = 0; i < s.x.size(); ++i) {
      take(s.x[i], s.y[i]);
      if (i < s.lo.size()) take(s.x[i], s.lo[i]);
      if (i < s.hi.size()) take(s.x[i], s.hi[i]);
    }
  }
  for (const PlotMarker& m : markers)
    if (m.sets_range) take(m.x, m.y);
  if (!std::isfinite(x0)) {
    x0 = 0;
    x1 = 1;
    y0 = 0;
    y1 = 1;
  }
  for (const PlotLine& l : lines) {
    if (l.slope == 0 && l.y > 0 && std::isfinite(l.y)) {
      y0 = std::min(y0, std::log10(l.y) + log_k);
      y1 = std::max(y1, std::log10(l.y) + log_k);
    }
  }
  x0 = std::floor(x0);
  x1 = std::max(std::ceil(x1), x0 + 1);
  y0 = std::floor(y0);
  y1 = std::max(std::ceil(y1), y0 + 1);

  const double left = 80, right = legend_width, top = 40, bottom = 55;
  const double pw = width - left - right, ph = height - top - bottom;
  auto px = [&](double x) { return left + (std::log10(x) - x0) / (x1 - x0) * pw; };
  // py: a displayed value; pyb: a value in the base unit.
  auto py = [&](double y) { return top + (y1 - std::log10(y)) / (y1 - y0) * ph; };
  auto pyb = [&](double y) { return py(y * k); };
  // The right axis (base unit), then the legend, as wide as its texts need.
  const double axis2_width = y2_label.empty() ? 0 : 62;
  double legend_need = 0;
  for (const PlotSeries& s : series)
    if (s.in_legend) legend_need = std::max(legend_need, 30 + TextWidth(s.label, kCharWidthPx));
  if (marker_labels_in_legend) {
    for (const PlotMarker& m : markers)
      legend_need = std::max(legend_need, 30 + TextWidth(m.label, kCharWidthPx));
  }
  for (const std::string& note : notes)
    legend_need = std::max(legend_need, TextWidth(note, kSmallCharWidthPx));
  legend_need += 12 + 8;  // the gap before it, a margin after
  const int total_width =
      static_cast<int>(std::ceil(width + axis2_width + std::max(0.0, legend_need - legend_width)));

  std::string svg;
  svg += "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + std::to_string(total_width) +
         "\" height=\"" + std::to_string(height) + "\" viewBox=\"0 0 " +
         std::to_string(total_width) + " " + std::to_string(height) +
         "\" font-family=\"sans-serif\" font-size=\"12\"";
  svg += " role=\"img\" aria-label=\"";
  svg += Esc(title);
  svg += "\">\n";
  svg += "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  svg += "<text x=\"" + F(left + pw / 2) + "\" y=\"22\" text-anchor=\"middle\" font-size=\"15\">" +
         Esc(title) + "</text>\n";
  // Grid: decades solid, 2..9 faint.
  for (double d = x0; d <= x1 + 1e-9; d += 1) {
    for (int k = 1; k < 10 && d + std::log10(k) <= x1 + 1e-9; ++k) {
      const double x = left + (d + std::log10(k) - x0) / (x1 - x0) * pw;
      svg += "<line x1=\"" + F(x) + "\" y1=\"" + F(top) + "\" x2=\"" + F(x) + "\" y2=\"" +
             F(top + ph) + "\" stroke=\"" + (k == 1 ? "#bbbbbb" : "#eeeeee") + "\"/>\n";
    }
    svg += "<text x=\"" + F(left + (d - x0) / (x1 - x0) * pw) + "\" y=\"" + F(top + ph + 18) +
           "\" text-anchor=\"middle\">" + Tick(d) + "</text>\n";
  }
  for (double d = y0; d <= y1 + 1e-9; d += 1) {
    for (int k = 1; k < 10 && d + std::log10(k) <= y1 + 1e-9; ++k) {
      const double y = top + (y1 - d - std::log10(k)) / (y1 - y0) * ph;
      svg += "<line x1=\"" + F(left) + "\" y1=\"" + F(y) + "\" x2=\"" + F(left + pw) + "\" y2=\"" +
             F(y) + "\" stroke=\"" + (k == 1 ? "#bbbbbb" : "#eeeeee") + "\"/>\n";
    }
    svg += "<text x=\"" + F(left - 8) + "\" y=\"" + F(top + (y1 - d) / (y1 - y0) * ph + 4) +
           "\" text-anchor=\"end\">" + Tick(d) + "</text>\n";
  }
  svg += "<rect x=\"" + F(left) + "\" y=\"" + F(top) + "\" width=\"" + F(pw) + "\" height=\"" +
         F(ph) + "\" fill=\"none\" stroke=\"#333333\"/>\n";
  svg += "<text x=\"" + F(left + pw / 2) + "\" y=\"" + F(height - 12.0) +
         "\" text-anchor=\"middle\">" + Esc(x_label) + "</text>\n";
  svg += "<text transform=\"translate(18," + F(top + ph / 2) +
         ") rotate(-90)\" text-anchor=\"middle\">" + Esc(y_label) + "</text>\n";
  if (!y2_label.empty()) {  // base-unit decades on the right
    for (double d = std::floor(y0 - log_k); d <= y1 - log_k + 1e-9; d += 1) {
      if (d + log_k < y0 - 1e-9) continue;
      const double y = top + (y1 - d - log_k) / (y1 - y0) * ph;
      svg += "<line x1=\"" + F(left + pw) + "\" y1=\"" + F(y) + "\" x2=\"" + F(left + pw + 5) +
             "\" y2=\"" + F(y) + "\" stroke=\"#333333\"/>\n";
      svg += "<text x=\"" + F(left + pw + 8) + "\" y=\"" + F(y + 4) + "\" fill=\"#555555\">" +
             Tick(d) + "</text>\n";
    }
    svg += "<text transform=\"translate(" + F(left + pw + axis2_width - 8) + "," + F(top + ph / 2) +
           ") rotate(-90)\" text-anchor=\"middle\" fill=\"#555555\">" + Esc(y2_label) + "</text>\n";
  }

  // Bands first, then lines and points on top.
  for (const PlotSeries& s : series) {
    if (s.lo.size() != s.x.size() || s.hi.size() != s.x.size()) continue;
    std::string upper, lower;
    for (size_t i = 0; i < s.x.size(); ++i) {
      if (!Drawable(s.x[i], s.lo[i]) || !Drawable(s.x[i], s.hi[i])) continue;
      upper += F(px(s.x[i])) + "," + F(pyb(s.hi[i])) + " ";
      lower = F(px(s.x[i])) + "," + F(pyb(s.lo[i])) + " " + lower;
    }
    if (!upper.empty()) {
      svg += "<polygon points=\"" + upper + lower + "\" fill=\"" + s.color +
             "\" fill-opacity=\"0.18\" stroke=\"none\"/>\n";
    }
  }
  // Reference lines, clipped to the plot; their labels come last (on top).
  std::vector<Segment> line_segments(lines.size());
  std::vector<bool> line_drawn(lines.size(), false);
  for (size_t li = 0; li < lines.size(); ++li) {
    const PlotLine& l = lines[li];
    if (!(l.y > 0) || !std::isfinite(l.y) || !std::isfinite(l.slope)) continue;
    // In decades: ly(lx) = log10(y) + slope lx, clipped to [x0, x1] x [y0, y1].
    double a = x0, b = x1;
    const double c = std::log10(l.y) + log_k;
    if (l.slope != 0) {
      double ea = (y0 - c) / l.slope, eb = (y1 - c) / l.slope;
      if (ea > eb) std::swap(ea, eb);
      a = std::max(a, ea);
      b = std::min(b, eb);
      if (!(b > a)) continue;  // entirely outside the plot
    }
    const double ya = std::pow(10.0, c + l.slope * a), yb = std::pow(10.0, c + l.slope * b);
    const double xa = std::pow(10.0, a), xb = std::pow(10.0, b);
    line_segments[li] = {px(xa), py(ya), px(xb), py(yb)};
    line_drawn[li] = true;
    svg += "<line x1=\"" + F(px(xa)) + "\" y1=\"" + F(py(ya)) + "\" x2=\"" + F(px(xb)) +
           "\" y2=\"" + F(py(yb)) + "\" stroke=\"" + l.color +
           "\" stroke-dasharray=\"6,4\" stroke-width=\"1.5\"/>\n";
  }
  for (const PlotSeries& s : series) {
    // The line in runs of drawable points inside the plot (a series that
    // does not set the range leaves it, and is not drawn there).
    std::vector<std::string> runs(1);
    auto inside = [&](size_t i) {
      if (!Drawable(s.x[i], s.y[i])) return false;
      const double y = pyb(s.y[i]);
      return s.sets_range || (y >= top - 0.5 && y <= top + ph + 0.5);
    };
    for (size_t i = 0; i < s.x.size(); ++i) {
      if (inside(i)) {
        runs.back() += F(px(s.x[i])) + "," + F(pyb(s.y[i])) + " ";
      } else if (!runs.back().empty()) {
        runs.emplace_back();
      }
    }
    if (runs.back().empty()) runs.pop_back();
    if (runs.empty()) continue;
    std::string opacity;
    if (s.opacity < 1) {
      opacity = " opacity=\"";
      opacity += F(std::max(s.opacity, 0.0));
      opacity += "\"";
    }
    if (!s.tooltip.empty()) svg += "<g><title>" + Esc(s.tooltip) + "</title>";
    for (const std::string& pts : runs) {
      svg += "<polyline points=\"" + pts + "\" fill=\"none\" stroke=\"" + s.color +
             "\" stroke-width=\"" + F(s.stroke_width) + "\"" +
             (s.dashed ? " stroke-dasharray=\"5,3\"" : "") + opacity + "/>\n";
    }
    if (s.markers) {
      for (size_t i = 0; i < s.x.size(); ++i) {
        if (!inside(i)) continue;
        svg += "<circle cx=\"" + F(px(s.x[i])) + "\" cy=\"" + F(pyb(s.y[i])) +
               "\" r=\"2.6\" fill=\"" + s.color + "\"" + opacity + "/>\n";
      }
    }
    if (!s.tooltip.empty()) svg += "</g>\n";
  }
  for (const PlotMarker& m : markers) {
    if (!Drawable(m.x, m.y)) continue;
    const double mx = px(m.x), my = pyb(m.y);
    if (mx < left - 0.5 || mx > left + pw + 0.5 || my < top - 0.5 || my > top + ph + 0.5) continue;
    svg += "<circle cx=\"" + F(mx) + "\" cy=\"" + F(my) + "\" r=\"5\" fill=\"none\" stroke=\"" +
           m.color + "\" stroke-width=\"2\"/>\n";
    if (marker_labels_in_legend || m.label.empty()) continue;
    // Below right of the ring, or on the side (and above) where the plot has room.
    const bool to_left = mx + 8 + TextWidth(m.label, kCharWidthPx) > left + pw;
    const bool above = my + 16 > top + ph - 2;
    svg += "<text x=\"" + F(to_left ? mx - 8 : mx + 8) + "\" y=\"" + F(above ? my - 9 : my + 16) +
           "\" fill=\"" + m.color + "\"" + (to_left ? " text-anchor=\"end\"" : "") + ">" +
           Esc(m.label) + "</text>\n";
  }
  // Line labels along their lines, each where it least overlaps the curves,
  // the markers, the other lines and the labels placed before it: the first
  // candidate with kLabelClearPx of free space, else the clearest one.
  {
    constexpr double kHalfHeightPx = 4.5;  // half the cap height
    constexpr double kLabelClearPx = 3;
    constexpr int kSamples = 8;
    std::vector<Segment> obstacles;
    for (const PlotSeries& s : series) {
      bool have = false;
      double lx = 0, ly = 0;
      for (size_t i = 0; i < s.x.size(); ++i) {
        if (!Drawable(s.x[i], s.y[i])) continue;
        const double x = px(s.x[i]), y = pyb(s.y[i]);
        if (have) obstacles.push_back({lx, ly, x, y});
        lx = x;
        ly = y;
        have = true;
      }
    }
    for (const PlotMarker& m : markers) {
      if (Drawable(m.x, m.y)) obstacles.push_back({px(m.x), pyb(m.y), px(m.x), pyb(m.y)});
    }
    std::vector<Segment> placed;  // centre lines of the labels already placed
    struct Candidate {
      double x, y;    // the anchor on the baseline
      double tx, ty;  // the text's direction (unit vector)
      bool anchor_end;
    };
    for (size_t li = 0; li < lines.size(); ++li) {
      if (!line_drawn[li] || lines[li].label.empty()) continue;
      const Segment& g = line_segments[li];
      const double len = std::hypot(g.bx - g.ax, g.by - g.ay);
      if (!(len > 0)) continue;
      const double dx = (g.bx - g.ax) / len, dy = (g.by - g.ay) / len;  // along the line
      const double w = TextWidth(lines[li].label, kCharWidthPx);
      // Along the line, ending at points from its right end backwards, the
      // baseline above then below it; then level text beside those points
      // (for a line too short or too steep to carry its label).
      std::vector<Candidate> candidates;
      for (const bool level : {false, true}) {
        const double tx = level ? 1 : dx, ty = level ? 0 : dy;
        const double nx = ty, ny = -tx;  // the text's "up"
        for (int step = 0; step <= 10; ++step) {
          const double px0 = g.ax + (1.0 - 0.1 * step) * len * dx;
          const double py0 = g.ay + (1.0 - 0.1 * step) * len * dy;
          for (const double offset : {4.0, -14.0}) {  // baseline above / below the line
            candidates.push_back(
                {px0 - 4 * tx + offset * nx, py0 - 4 * ty + offset * ny, tx, ty, true});
            if (level) {
              candidates.push_back(
                  {px0 + 4 * tx + offset * nx, py0 + 4 * ty + offset * ny, tx, ty, false});
            }
          }
        }
      }
      auto score_of = [&](const Candidate& c) {
        const double nx = c.ty, ny = -c.tx;
        const double sign = c.anchor_end ? -1 : 1;
        double score = std::numeric_limits<double>::infinity();
        for (int k = 0; k <= kSamples; ++k) {
          const double cx = c.x + sign * c.tx * w * k / kSamples + nx * kHalfHeightPx;
          const double cy = c.y + sign * c.ty * w * k / kSamples + ny * kHalfHeightPx;
          if (cx < left || cx > left + pw || cy - kHalfHeightPx < top ||
              cy + kHalfHeightPx > top + ph) {
            return -std::numeric_limits<double>::infinity();
          }
          for (const Segment& o : obstacles) score = std::min(score, Distance(cx, cy, o));
          for (const Segment& o : placed) score = std::min(score, Distance(cx, cy, o));
          for (size_t other = 0; other < lines.size(); ++other) {
            if (other != li && line_drawn[other]) {
              score = std::min(score, Distance(cx, cy, line_segments[other]));
            }
          }
        }
        return score - kHalfHeightPx;
      };
      const Candidate* best = nullptr;
      double best_score = -std::numeric_limits<double>::infinity();
      for (const Candidate& c : candidates) {
        const double score = score_of(c);
        if (best == nullptr || score > best_score) {
          best = &c;
          best_score = score;
        }
        if (score >= kLabelClearPx) break;
      }
      Candidate c = *best;
      if (!std::isfinite(best_score)) {  // nowhere inside: level, clamped into the plot
        c = {std::clamp(g.bx - 4, left + w, left + pw - 4),
             std::clamp(g.by - 4, top + 12, top + ph - 4), 1, 0, true};
      }
      const double nx = c.ty, ny = -c.tx, sign = c.anchor_end ? -1 : 1;
      const double cx = c.x + nx * kHalfHeightPx, cy = c.y + ny * kHalfHeightPx;
      placed.push_back({cx, cy, cx + sign * c.tx * w, cy + sign * c.ty * w});
      svg += "<text x=\"" + F(c.x) + "\" y=\"" + F(c.y) + "\" text-anchor=\"" +
             (c.anchor_end ? "end" : "start") + "\" fill=\"" + lines[li].color + "\"";
      const double angle_deg = std::atan2(c.ty, c.tx) * 180 / std::numbers::pi;
      if (std::abs(angle_deg) > 0.05) {
        svg += " transform=\"rotate(" + F(angle_deg) + " " + F(c.x) + " " + F(c.y) + ")\"";
      }
      svg += ">" + Esc(lines[li].label) + "</text>\n";
    }
  }
  // Legend: series, then (optionally) markers, then notes; what does not fit
  // above the bottom margin is counted instead of drawn.
  const double legend_x = left + pw + axis2_width + 12, legend_end = height - bottom;
  double ly = top + 10;
  size_t not_shown = 0;
  auto room = [&](double need) { return ly + need <= legend_end; };
  for (const PlotSeries& s : series) {
    if (!s.in_legend) continue;
    if (!room(18 + 18)) {
      ++not_shown;
      continue;
    }
    svg += "<line x1=\"" + F(legend_x) + "\" y1=\"" + F(ly) + "\" x2=\"" + F(legend_x + 24) +
           "\" y2=\"" + F(ly) + "\" stroke=\"" + s.color + "\" stroke-width=\"2\"" +
           (s.dashed ? " stroke-dasharray=\"5,3\"" : "") + "/>\n";
    svg += "<text x=\"" + F(legend_x + 30) + "\" y=\"" + F(ly + 4) + "\">" + Esc(s.label) +
           "</text>\n";
    ly += 18;
  }
  if (marker_labels_in_legend) {
    for (const PlotMarker& m : markers) {
      if (!Drawable(m.x, m.y) || m.label.empty()) continue;
      if (!room(18 + 18)) {
        ++not_shown;
        continue;
      }
      svg += "<circle cx=\"" + F(legend_x + 12) + "\" cy=\"" + F(ly) +
             "\" r=\"5\" fill=\"none\" stroke=\"" + m.color + "\" stroke-width=\"2\"/>\n";
      svg += "<text x=\"" + F(legend_x + 30) + "\" y=\"" + F(ly + 4) + "\">" + Esc(m.label) +
             "</text>\n";
      ly += 18;
    }
  }
  if (not_shown > 0) {
    svg += "<text x=\"" + F(legend_x) + "\" y=\"" + F(ly + 4) + "\" fill=\"#555555\">(" +
           std::to_string(not_shown) + " more not listed)</text>\n";
    ly += 18;
  }
  ly += 6;
  for (const std::string& note : notes) {
    if (!room(14)) break;
    svg += "<text x=\"" + F(legend_x) + "\" y=\"" + F(ly + 4) +
           "\" font-size=\"10.5\" fill=\"#555555\">" + Esc(note) + "</text>\n";
    ly += 14;
  }
  svg += "</svg>\n";
  return svg;
}

}  // namespace imuqual::report
