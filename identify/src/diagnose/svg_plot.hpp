// A tiny inline-SVG plotting layer for the diagnosis report (report.cpp):
// axes with ticks and labels, scatter markers, lines, bars, arrows and a
// sequential colour map. Private to identify/: the report must open offline,
// so it carries its own pictures instead of a charting library or script.
#pragma once

#include <sstream>
#include <string>
#include <string_view>
#include <vector>

namespace kincal::identify::svg {

// Text for HTML/SVG content and attribute values: & < > " ' escaped, control
// characters dropped (a CSV label could carry anything).
std::string escape(std::string_view text);

// Locale-independent number text, `digits` significant digits, "n/a" for
// NaN/Inf, so a bad value shows up instead of breaking the layout.
std::string num(double value, int digits = 3);
// Fixed decimals, for coordinates and percentages ("n/a" if not finite).
std::string fixed(double value, int decimals);

// Data range of the finite values (lo > hi when there is none).
struct Range {
  double lo = 1, hi = 0;
  bool empty() const { return !(lo <= hi); }
  void add(double v);
};

// One axis: the data interval and whether it is logarithmic. `ticks()` gives
// "nice" values (1-2-5 steps, or decades on a log axis).
struct Axis {
  double lo = 0, hi = 1;
  bool log = false;
  std::string label;
  std::vector<double> ticks(int target = 5) const;
  // Position of `v` in [0, 1] along the axis (clamped a little outside).
  double fraction(double v) const;
};

// An axis that covers `r` with a margin; from zero when `from_zero`; on a log
// scale when `allow_log` and the positive values span more than `log_span`.
Axis fit_axis(Range r, bool from_zero, bool allow_log, double log_span = 30.0);

// Sequential colour map for residual magnitude: pale yellow (small) through
// orange to dark red (large); t in [0, 1].
std::string heat_colour(double t);

struct Margins {
  double left = 56, right = 12, top = 26, bottom = 40;
};

// One SVG picture with a plotting area. Data coordinates go through the axes;
// *_px calls take pixel coordinates of the picture.
class Plot {
 public:
  Plot(double width, double height, Margins margins = {});

  void set_axes(Axis x, Axis y);
  const Axis& x_axis() const { return x_; }
  const Axis& y_axis() const { return y_; }
  double px(double x) const;  // data x -> pixel
  double py(double y) const;  // data y -> pixel
  double left() const { return m_.left; }
  double right() const { return w_ - m_.right; }
  double top() const { return m_.top; }
  double bottom() const { return h_ - m_.bottom; }
  bool inside(double x, double y) const;  // data point lands in the plotting area

  void title(const std::string& text);
  // Frame, grid, ticks and tick labels, axis labels. `x_ticks=false` for a
  // categorical x axis whose labels the caller draws.
  void draw_axes(bool x_ticks = true, bool grid = true);

  // Markers in data coordinates; `cls` selects the CSS style, `fill` (a
  // colour) overrides its fill.
  void circle(double x, double y, double r, const std::string& cls, const std::string& tooltip = {},
              const std::string& fill = {});
  void diamond(double x, double y, double r, const std::string& cls, const std::string& tooltip = {},
               const std::string& fill = {});
  // Many markers as one <path> each: a dot is a zero-length segment with a
  // round cap ("M x y h0"), a diamond a closed subpath. ~15 bytes a point
  // instead of ~50 for separate elements; the report draws thousands.
  void dots(const std::vector<double>& xs, const std::vector<double>& ys, const std::vector<bool>& keep,
            const std::string& cls);
  void diamonds(const std::vector<double>& xs, const std::vector<double>& ys, const std::vector<bool>& keep, double r,
                const std::string& cls);
  void polyline(const std::vector<double>& xs, const std::vector<double>& ys, const std::string& cls);
  void hline(double y, const std::string& cls, const std::string& label = {});
  void vline(double x, const std::string& cls, const std::string& label = {});

  // Pixel-space primitives.
  void rect_px(double x, double y, double w, double h, const std::string& style_or_cls, bool is_class = true,
               const std::string& tooltip = {});
  void line_px(double x0, double y0, double x1, double y1, const std::string& cls);
  void arrow_px(double x0, double y0, double x1, double y1, const std::string& cls);
  void text_px(double x, double y, const std::string& text, const std::string& cls = {},
               const char* anchor = "middle", double rotate = 0);
  void raw(const std::string& svg_fragment) { body_ << svg_fragment; }

  std::string str() const;

 private:
  double w_, h_;
  Margins m_;
  Axis x_, y_;
  std::ostringstream body_;
};

// A horizontal colour bar for `heat_colour` over the axis `scale`, with ticks
// and an optional marker (e.g. the noise level).
std::string colour_legend(const Axis& scale, double width, const std::string& label, double marker = -1,
                          const std::string& marker_label = {});

// The <defs> every picture refers to (the arrow head), in one hidden <svg>
// placed once at the top of the page.
std::string shared_defs();

}  // namespace kincal::identify::svg
