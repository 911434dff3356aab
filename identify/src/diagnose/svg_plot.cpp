#include "diagnose/svg_plot.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>

namespace kincal::identify::svg {

std::string escape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default:
        // Control characters are not allowed in HTML text; tabs/newlines
        // become a space so a multi-line note stays readable.
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f)
          out += (c == '\t' || c == '\n' || c == '\r') ? ' ' : '?';
        else
          out += c;
    }
  }
  return out;
}

namespace {

std::string chars(double value, std::chars_format format, int precision) {
  // to_chars is locale-independent: a report written under a German locale
  // must still say 1.5, not 1,5 (and the SVG coordinates must parse).
  std::array<char, 64> buf{};
  const auto res = std::to_chars(buf.data(), buf.data() + buf.size(), value, format, precision);
  if (res.ec != std::errc()) return "n/a";
  return std::string(buf.data(), res.ptr);
}

}  // namespace

std::string num(double value, int digits) {
  if (!std::isfinite(value)) return "n/a";
  if (value == 0) return "0";
  const double a = std::fabs(value);
  if (a >= 1e-3 && a < 1e7) {
    const int magnitude = static_cast<int>(std::floor(std::log10(a)));
    const int decimals = std::max(0, digits - 1 - magnitude);
    return chars(value, std::chars_format::fixed, decimals);
  }
  return chars(value, std::chars_format::scientific, std::max(0, digits - 1));
}

std::string fixed(double value, int decimals) {
  if (!std::isfinite(value)) return "n/a";
  std::string s = chars(value, std::chars_format::fixed, decimals);
  if (s == "-0" || s == "-0.0" || s == "-0.00") s.erase(0, 1);  // no "-0" from rounding
  return s;
}

void Range::add(double v) {
  if (!std::isfinite(v)) return;
  if (empty()) {
    lo = hi = v;
  } else {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
}

namespace {

double nice_step(double span, int target) {
  const double raw = span / std::max(1, target);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / mag;
  const double nice = f < 1.5 ? 1 : f < 3 ? 2 : f < 7 ? 5 : 10;
  return nice * mag;
}

}  // namespace

std::vector<double> Axis::ticks(int target) const {
  std::vector<double> out;
  if (!(hi > lo) || !std::isfinite(lo) || !std::isfinite(hi)) return out;
  if (log && lo > 0) {
    const int k0 = static_cast<int>(std::ceil(std::log10(lo) - 1e-9));
    const int k1 = static_cast<int>(std::floor(std::log10(hi) + 1e-9));
    // Fewer than two decades inside: add the 2 and 5 multiples so the reader
    // still has something to read values against.
    const bool dense = k1 - k0 < 2;
    const int step = std::max(1, (k1 - k0 + 1) / 8);  // at most ~8 decade labels
    for (int k = k0 - 1; k <= k1; ++k) {
      const double d = std::pow(10.0, k);
      if (d >= lo * (1 - 1e-9) && d <= hi * (1 + 1e-9) && (k - k0) % step == 0) out.push_back(d);
      if (dense)
        for (double m : {2.0, 5.0})
          if (m * d >= lo && m * d <= hi) out.push_back(m * d);
    }
    std::sort(out.begin(), out.end());
    return out;
  }
  // The finest 1-2-5 step that gives at most target + 1 labels.
  double step = nice_step(hi - lo, target);
  for (int guard = 0; guard < 8 && std::floor(hi / step + 1e-9) - std::ceil(lo / step - 1e-9) + 1 > target + 1; ++guard) {
    const double mag = std::pow(10.0, std::floor(std::log10(step) + 1e-9));
    const double f = std::round(step / mag);
    step = (f < 2 ? 2 : f < 5 ? 5 : 10) * mag;
  }
  for (double t = std::ceil(lo / step - 1e-9) * step; t <= hi + step * 1e-9; t += step)
    out.push_back(std::fabs(t) < step * 1e-9 ? 0.0 : t);
  return out;
}

double Axis::fraction(double v) const {
  double f = 0;
  if (log) {
    if (!(v > 0) || !(lo > 0)) return -0.05;
    f = (std::log10(v) - std::log10(lo)) / (std::log10(hi) - std::log10(lo));
  } else {
    f = (v - lo) / (hi - lo);
  }
  // Clamped so a stray value cannot produce a coordinate of 1e300 in the SVG.
  if (!std::isfinite(f)) return 0.5;
  return std::clamp(f, -0.05, 1.05);
}

Axis fit_axis(Range r, bool from_zero, bool allow_log, double log_span) {
  Axis a;
  if (r.empty()) return a;  // [0, 1]
  if (allow_log && r.lo > 0 && r.hi / r.lo > log_span) {
    a.log = true;
    a.lo = r.lo / 1.5;
    a.hi = r.hi * 1.5;
    return a;
  }
  double lo = r.lo, hi = r.hi;
  if (from_zero) {
    lo = std::min(lo, 0.0);
    hi = std::max(hi, 0.0);
  }
  if (hi - lo <= 0) {
    const double pad = lo == 0 ? 1.0 : std::fabs(lo) * 0.1;
    lo -= pad;
    hi += pad;
  }
  const double pad = 0.06 * (hi - lo);
  a.lo = (from_zero && lo == 0) ? 0 : lo - pad;
  a.hi = (from_zero && hi == 0) ? 0 : hi + pad;
  return a;
}

std::string heat_colour(double t) {
  // Pale for small errors (at the noise level the map should look quiet),
  // dark red for large ones; monotone in lightness so it reads in grey too.
  static constexpr std::array<std::array<double, 3>, 5> stops{{
      {255, 255, 204}, {254, 217, 118}, {253, 141, 60}, {227, 26, 28}, {128, 0, 38}}};
  if (!std::isfinite(t)) return "#cccccc";
  t = std::clamp(t, 0.0, 1.0) * static_cast<double>(stops.size() - 1);
  const std::size_t i = std::min(static_cast<std::size_t>(t), stops.size() - 2);
  const double f = t - static_cast<double>(i);
  std::string out = "#";
  static constexpr char hex[] = "0123456789abcdef";
  for (std::size_t c = 0; c < 3; ++c) {
    const int v = static_cast<int>(std::lround(stops[i][c] + f * (stops[i + 1][c] - stops[i][c])));
    out += hex[(v >> 4) & 15];
    out += hex[v & 15];
  }
  return out;
}

Plot::Plot(double width, double height, Margins margins) : w_(width), h_(height), m_(margins) {}

void Plot::set_axes(Axis x, Axis y) {
  x_ = std::move(x);
  y_ = std::move(y);
}

double Plot::px(double x) const { return left() + x_.fraction(x) * (right() - left()); }
double Plot::py(double y) const { return bottom() - y_.fraction(y) * (bottom() - top()); }

bool Plot::inside(double x, double y) const {
  if (!std::isfinite(x) || !std::isfinite(y)) return false;
  const double fx = x_.fraction(x), fy = y_.fraction(y);
  return fx >= 0 && fx <= 1 && fy >= 0 && fy <= 1;
}

void Plot::title(const std::string& text) { text_px(w_ / 2, 16, text, "ttl"); }

namespace {

// Tick text with no more digits than the tick step needs ("-10", not
// "-10.0"), so the labels of a small panel do not run into each other.
std::string tick_text(double t, const Axis& a, const std::vector<double>& ticks) {
  if (a.log || ticks.size() < 2) {
    std::string s = num(t, 3);
    if (s.find('.') != std::string::npos && s.find('e') == std::string::npos) {
      while (s.back() == '0') s.pop_back();
      if (s.back() == '.') s.pop_back();
    }
    return s;
  }
  const double step = ticks[1] - ticks[0];
  if (std::fabs(t) >= 1e6 || step < 1e-6) return num(t, 3);
  const int decimals = std::clamp(static_cast<int>(-std::floor(std::log10(step) + 1e-9)), 0, 6);
  return fixed(t, decimals);
}

}  // namespace

void Plot::draw_axes(bool x_ticks, bool grid) {
  if (grid) {
    const auto yt = y_.ticks();
    for (double t : yt) {
      const double y = py(t);
      line_px(left(), y, right(), y, "grid");
      text_px(left() - 4, y + 3.5, tick_text(t, y_, yt), "tick", "end");
    }
    // About one label per 60 px: a 150-px panel gets three or four.
    const auto xt = x_.ticks(std::clamp(static_cast<int>((right() - left()) / 50), 3, 8));
    if (x_ticks)
      for (double t : xt) {
        const double x = px(t);
        line_px(x, top(), x, bottom(), "grid");
        text_px(x, bottom() + 13, tick_text(t, x_, xt), "tick");
      }
  }
  rect_px(left(), top(), right() - left(), bottom() - top(), "frame");
  if (!x_.label.empty()) text_px((left() + right()) / 2, h_ - 6, x_.label, "lbl");
  if (!y_.label.empty()) text_px(12, (top() + bottom()) / 2, y_.label, "lbl", "middle", -90);
}

namespace {

std::string tip(const std::string& tooltip) {
  return tooltip.empty() ? std::string() : "<title>" + escape(tooltip) + "</title>";
}

}  // namespace

void Plot::circle(double x, double y, double r, const std::string& cls, const std::string& tooltip,
                  const std::string& fill) {
  if (!inside(x, y)) return;
  body_ << "<circle cx=\"" << fixed(px(x), 1) << "\" cy=\"" << fixed(py(y), 1) << "\" r=\"" << fixed(r, 1)
        << "\" class=\"" << cls << '"';
  if (!fill.empty()) body_ << " style=\"fill:" << fill << '"';
  if (tooltip.empty())
    body_ << "/>";
  else
    body_ << '>' << tip(tooltip) << "</circle>";
}

void Plot::diamond(double x, double y, double r, const std::string& cls, const std::string& tooltip,
                   const std::string& fill) {
  if (!inside(x, y)) return;
  const double cx = px(x), cy = py(y);
  body_ << "<path d=\"M" << fixed(cx, 1) << ',' << fixed(cy - r, 1) << 'l' << fixed(r, 1) << ',' << fixed(r, 1)
        << 'l' << fixed(-r, 1) << ',' << fixed(r, 1) << 'l' << fixed(-r, 1) << ',' << fixed(-r, 1) << "z\" class=\""
        << cls << '"';
  if (!fill.empty()) body_ << " style=\"fill:" << fill << '"';
  if (tooltip.empty())
    body_ << "/>";
  else
    body_ << '>' << tip(tooltip) << "</path>";
}

void Plot::dots(const std::vector<double>& xs, const std::vector<double>& ys, const std::vector<bool>& keep,
                const std::string& cls) {
  std::string d;
  for (std::size_t i = 0; i < std::min(xs.size(), ys.size()); ++i)
    if ((i >= keep.size() || keep[i]) && inside(xs[i], ys[i]))
      d += 'M' + fixed(px(xs[i]), 1) + ' ' + fixed(py(ys[i]), 1) + "h0";
  if (!d.empty()) body_ << "<path d=\"" << d << "\" class=\"" << cls << "\"/>";
}

void Plot::diamonds(const std::vector<double>& xs, const std::vector<double>& ys, const std::vector<bool>& keep,
                    double r, const std::string& cls) {
  const std::string a = fixed(r, 1), b = fixed(-r, 1);
  std::string d;
  for (std::size_t i = 0; i < std::min(xs.size(), ys.size()); ++i)
    if ((i >= keep.size() || keep[i]) && inside(xs[i], ys[i]))
      d += 'M' + fixed(px(xs[i]), 1) + ' ' + fixed(py(ys[i]) - r, 1) + 'l' + a + ' ' + a + ' ' + b + ' ' + a + ' ' + b +
           ' ' + b + 'z';
  if (!d.empty()) body_ << "<path d=\"" << d << "\" class=\"" << cls << "\"/>";
}

void Plot::polyline(const std::vector<double>& xs, const std::vector<double>& ys, const std::string& cls) {
  std::string points;
  for (std::size_t i = 0; i < std::min(xs.size(), ys.size()); ++i) {
    if (!std::isfinite(xs[i]) || !std::isfinite(ys[i])) continue;
    points += fixed(px(xs[i]), 1) + ',' + fixed(py(ys[i]), 1) + ' ';
  }
  if (points.empty()) return;
  body_ << "<polyline points=\"" << points << "\" class=\"" << cls << "\"/>";
}

void Plot::hline(double y, const std::string& cls, const std::string& label) {
  if (!std::isfinite(y)) return;
  const double f = y_.fraction(y);
  if (f < 0 || f > 1) return;
  line_px(left(), py(y), right(), py(y), cls);
  if (!label.empty()) text_px(right() - 3, py(y) - 3, label, "nl", "end");
}

void Plot::vline(double x, const std::string& cls, const std::string& label) {
  if (!std::isfinite(x)) return;
  const double f = x_.fraction(x);
  if (f < 0 || f > 1) return;
  line_px(px(x), top(), px(x), bottom(), cls);
  if (!label.empty()) text_px(px(x) + 3, top() + 10, label, "nl", "start");
}

void Plot::rect_px(double x, double y, double w, double h, const std::string& style_or_cls, bool is_class,
                   const std::string& tooltip) {
  body_ << "<rect x=\"" << fixed(x, 1) << "\" y=\"" << fixed(y, 1) << "\" width=\"" << fixed(std::max(0.0, w), 1)
        << "\" height=\"" << fixed(std::max(0.0, h), 1) << '"';
  if (is_class)
    body_ << " class=\"" << style_or_cls << '"';
  else
    body_ << " fill=\"" << style_or_cls << '"';
  if (tooltip.empty())
    body_ << "/>";
  else
    body_ << '>' << tip(tooltip) << "</rect>";
}

void Plot::line_px(double x0, double y0, double x1, double y1, const std::string& cls) {
  body_ << "<line x1=\"" << fixed(x0, 1) << "\" y1=\"" << fixed(y0, 1) << "\" x2=\"" << fixed(x1, 1) << "\" y2=\""
        << fixed(y1, 1) << "\" class=\"" << cls << "\"/>";
}

void Plot::arrow_px(double x0, double y0, double x1, double y1, const std::string& cls) {
  // Shorter than the head itself: the arrow would be a misleading blob.
  if (std::hypot(x1 - x0, y1 - y0) < 2.5) return;
  body_ << "<line x1=\"" << fixed(x0, 1) << "\" y1=\"" << fixed(y0, 1) << "\" x2=\"" << fixed(x1, 1) << "\" y2=\""
        << fixed(y1, 1) << "\" class=\"" << cls << "\" marker-end=\"url(#kc-ah)\"/>";
}

void Plot::text_px(double x, double y, const std::string& text, const std::string& cls, const char* anchor,
                   double rotate) {
  body_ << "<text x=\"" << fixed(x, 1) << "\" y=\"" << fixed(y, 1) << '"';
  if (!cls.empty()) body_ << " class=\"" << cls << '"';
  if (std::string_view(anchor) != "start") body_ << " text-anchor=\"" << anchor << '"';
  if (rotate != 0)
    body_ << " transform=\"rotate(" << fixed(rotate, 0) << ' ' << fixed(x, 1) << ' ' << fixed(y, 1) << ")\"";
  body_ << '>' << escape(text) << "</text>";
}

std::string Plot::str() const {
  return "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + fixed(w_, 0) + "\" height=\"" + fixed(h_, 0) +
         "\" viewBox=\"0 0 " + fixed(w_, 0) + ' ' + fixed(h_, 0) + "\">" + body_.str() + "</svg>";
}

std::string colour_legend(const Axis& scale, double width, const std::string& label, double marker,
                          const std::string& marker_label) {
  Margins m;
  m.left = 14;
  m.right = 14;
  m.top = 30;
  m.bottom = 20;
  Plot p(width, 64, m);
  Axis y;
  p.set_axes(scale, y);
  p.text_px(p.left(), 12, label, "lbl", "start");
  p.rect_px(p.left(), p.top(), p.right() - p.left(), p.bottom() - p.top(), "url(#kc-heat)", false);
  p.rect_px(p.left(), p.top(), p.right() - p.left(), p.bottom() - p.top(), "frame");
  for (double t : scale.ticks(6)) {
    const double x = p.px(t);
    p.line_px(x, p.bottom(), x, p.bottom() + 3, "frame");
    p.text_px(x, p.bottom() + 13, tick_text(t, scale, scale.ticks(6)), "tick");
  }
  if (marker > 0 && std::isfinite(marker)) {
    const double f = scale.fraction(marker);
    if (f >= 0 && f <= 1) {
      const double x = p.px(marker);
      p.line_px(x, p.top() - 4, x, p.bottom() + 3, "noise");
      // Below the title line, just above the bar: the title is long.
      if (!marker_label.empty()) p.text_px(x + 3, p.top() - 3, marker_label, "nl", "start");
    }
  }
  return p.str();
}

std::string shared_defs() {
  // The heat gradient repeats heat_colour's stops so the legend bar matches
  // the tiles exactly (the colour is a function of the axis fraction).
  std::string stops;
  for (int i = 0; i <= 4; ++i) {
    const double t = i / 4.0;
    stops += "<stop offset=\"" + fixed(t, 2) + "\" stop-color=\"" + heat_colour(t) + "\"/>";
  }
  // Not display:none: Chromium does not render markers from an undisplayed SVG.
  return "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"0\" height=\"0\" style=\"position:absolute\" "
         "aria-hidden=\"true\"><defs>"
         "<marker id=\"kc-ah\" viewBox=\"0 0 10 10\" refX=\"9\" refY=\"5\" markerWidth=\"5\" markerHeight=\"5\" "
         "orient=\"auto\"><path d=\"M0,0L10,5L0,10z\" fill=\"#111\"/></marker>"
         "<linearGradient id=\"kc-heat\" x1=\"0\" x2=\"1\" y1=\"0\" y2=\"0\">" +
         stops + "</linearGradient></defs></svg>";
}

}  // namespace kincal::identify::svg
