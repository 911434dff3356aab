// The diagnosis report (`kincal diagnose --report REPORT.html`, issue #4 item
// 3): one self-contained HTML file, inline CSS and SVG only, no script and no
// external resource, so it opens offline and can be mailed or archived with
// the data. docs/diagnosis-report.md explains how to read each picture.
#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "kincal/identify/diagnosis.hpp"
#include "kincal/identify/version.hpp"
#include "diagnose/svg_plot.hpp"

namespace kincal::identify {

namespace {

using svg::escape;
using svg::fixed;
using svg::num;

constexpr double kPi = 3.14159265358979323846;

bool finite_positive(double v) { return std::isfinite(v) && v > 0; }

// RMS per coordinate of 3-vectors, the convention of DIAG.json's rms_um.
double rms_per_coordinate(const std::vector<Vec3<double>>& r) {
  double sum = 0;
  std::size_t n = 0;
  for (const auto& v : r)
    if (v.allFinite()) {
      sum += v.squaredNorm();
      n += 3;
    }
  return n ? std::sqrt(sum / static_cast<double>(n)) : std::nan("");
}

// Which joints are revolute (shown in degrees, residuals in µrad) is the
// robot's word, carried by the diagnosis (Robot::revolute).
bool revolute_joint(const Diagnosis& d, int i) { return d.revolute[std::size_t(i)]; }
double joint_display(const Diagnosis& d, int i, double q) { return revolute_joint(d, i) ? q * (180.0 / kPi) : q; }
const char* joint_unit(const Diagnosis& d, int i) { return revolute_joint(d, i) ? "deg" : "mm"; }
const char* joint_residual_unit(const Diagnosis& d, int i) { return revolute_joint(d, i) ? "µrad" : "µm"; }

std::string rms_with_ratio(double rms, double noise) {
  std::string s = num(rms, 3) + " µm";
  if (finite_positive(noise) && std::isfinite(rms)) s += " <span class=\"dim\">(" + num(rms / noise, 3) + "× σ)</span>";
  return s;
}

// ------------------------------------------------------------------ styles

const char* kStyle = R"CSS(
body{font:14px/1.4 system-ui,-apple-system,"Segoe UI",Roboto,Helvetica,Arial,sans-serif;color:#1d1d1f;margin:0;background:#f5f5f7}
main{max-width:1400px;margin:0 auto;padding:16px 20px 40px}
h1{font-size:22px;margin:4px 0 10px}h2{font-size:18px;margin:26px 0 6px;border-bottom:1px solid #ccc;padding-bottom:3px}
h3{font-size:15px;margin:14px 0 4px}
p.how{color:#444;margin:4px 0 10px;max-width:1100px}
.card{background:#fff;border:1px solid #ddd;border-radius:6px;padding:10px 14px;margin:8px 0}
.kv{border-collapse:collapse}.kv td{padding:2px 14px 2px 0;vertical-align:top}.kv td:first-child{color:#555}
.badge{display:inline-block;padding:3px 12px;border-radius:12px;font-weight:600;color:#fff;letter-spacing:.3px}
.v-consistent{background:#2e7d32}.v-explained{background:#1565c0}.v-unexplained{background:#c62828}.v-unknown{background:#757575}
.dim{color:#666}.notes{background:#fff8e1;border:1px solid #f0c36d;border-radius:6px;padding:6px 14px;margin:8px 0}
.notes ul{margin:4px 0;padding-left:20px}
table.t{border-collapse:collapse;background:#fff;margin:6px 0;font-size:13px}
table.t th,table.t td{border:1px solid #ddd;padding:3px 8px;text-align:right;white-space:nowrap}
table.t th{background:#eef0f3;text-align:center}table.t td.l{text-align:left}
table.t tr.acc td{background:#e8f5e9}table.t tr.nt td{color:#777;background:#fafafa}
.row{display:flex;flex-wrap:wrap;gap:8px;align-items:flex-start}
.panel{background:#fff;border:1px solid #ddd;border-radius:6px;padding:4px}
.layers{display:flex;flex-wrap:wrap;gap:8px 22px}.layer{margin:6px 0 6px}.layer h3{margin:6px 0 2px}
.bar{position:relative;width:260px;height:14px;background:#f0f0f0;border-radius:2px}
.bar i{position:absolute;left:0;top:0;bottom:0;border-radius:2px}
.bar i.ok{background:#66bb6a}.bar i.mid{background:#ffa726}.bar i.bad{background:#e53935}
.bar b{position:absolute;top:-3px;bottom:-3px;border-left:2px dashed #222}
.hot{margin:4px 0;padding-left:22px}.hot li{margin:3px 0}.kind{display:inline-block;min-width:70px;font-weight:600;color:#c62828}
footer{color:#777;font-size:12px;margin-top:30px}
svg text{font-family:system-ui,Helvetica,Arial,sans-serif;font-size:11px;fill:#222}
svg text.ttl{font-size:12px;font-weight:600}svg text.lbl{font-size:11px;fill:#333}svg text.tick{font-size:10px;fill:#555}
svg text.nl{font-size:10px;fill:#000}svg text.val{font-size:10px;fill:#333;paint-order:stroke;stroke:#fff;stroke-width:3px}
svg .frame{fill:none;stroke:#888;stroke-width:1}svg .grid{stroke:#e6e6e6;stroke-width:1}
svg .zero{stroke:#999;stroke-width:1}svg .noise{stroke:#000;stroke-width:1.3;stroke-dasharray:5 3;fill:none}
svg .tile{stroke:#fff;stroke-width:.5}
svg .nc{stroke:#111;stroke-width:3.6;stroke-linecap:round}svg .nt{fill:#fff;stroke:#111;stroke-width:1.2}
svg .arrow{stroke:#111;stroke-width:1.3}svg .mc{stroke:#333;stroke-width:.7}svg .mt{stroke:#111;stroke-width:1.3}
svg .pb{stroke:#e65100;stroke-opacity:.75;stroke-width:4;stroke-linecap:round}svg .pa{stroke:#1565c0;stroke-opacity:.75;stroke-width:4;stroke-linecap:round}
svg .pbt{fill:#fff;stroke:#e65100;stroke-width:1.2}svg .pat{fill:#fff;stroke:#1565c0;stroke-width:1.2}
svg .bc{fill:#5c6bc0}svg .bt{fill:#ef6c00}svg .lg{fill:none;stroke:#888}
)CSS";

// ------------------------------------------------------------------ header

std::string verdict_class(const std::string& v) {
  if (v == "consistent" || v == "explained" || v == "unexplained") return "v-" + v;
  return "v-unknown";
}

void write_header(std::ostringstream& h, const Diagnosis& d) {
  const double noise = d.noise_um;
  h << "<h1>kincal diagnosis" << (d.robot.empty() ? "" : " — " + escape(d.robot)) << "</h1>\n";
  h << "<div class=\"card\"><p style=\"margin:2px 0 8px\">Verdict: <span class=\"badge "
    << verdict_class(d.verdict) << "\">" << escape(d.verdict.empty() ? "none" : d.verdict) << "</span> ";
  if (d.verdict == "consistent")
    h << "the base model fits to the noise level; no effect needs adding.";
  else if (d.verdict == "explained")
    h << "the accepted effects bring the held-out residual to the noise level.";
  else if (d.verdict == "unexplained")
    h << "a systematic residual remains; see <a href=\"#hotspots\">hotspots</a> for where it concentrates.";
  else if (d.verdict == "noise-unknown")
    h << "the noise could not be estimated reliably from these data, so the residual cannot be judged against it; "
         "give it with <code>--noise-um</code> (see the notes).";
  h << "</p>\n<table class=\"kv\">";
  auto row = [&](const std::string& k, const std::string& v_html) {
    h << "<tr><td>" << k << "</td><td>" << v_html << "</td></tr>";
  };
  row("Robot", escape(d.robot.empty() ? "—" : d.robot));
  row("Data file", escape(d.data_file.empty() ? "—" : d.data_file));
  row("Family", escape(d.family.empty() ? "—" : d.family));
  row("Nodes", std::to_string(d.rms.cal_nodes) + " cal, " + std::to_string(d.rms.test_nodes) + " test (held out)");
  if (!d.outliers.flagged.empty()) {
    std::string list;
    for (const NodeTest& t : d.outliers.flagged)
      list += (list.empty() ? "" : "<br>") + escape(t.id) + " <span class=\"dim\">(line " + std::to_string(t.line) +
              ", F = " + num(t.f, 3) + ", p = " + num(t.p_value, 2) + ")</span>";
    row("Outliers", list + "<br>" +
                        (d.outliers.excluded ? std::string("left out of the fit (keep them with --keep-outliers)")
                         : d.outliers.systematic
                             ? std::string("not left out: the misfit is systematic, not a few bad nodes")
                             : std::string("kept (--keep-outliers)")));
  }
  row("Noise σ", finite_positive(noise)
                     ? num(noise, 3) + " µm per position coordinate <span class=\"dim\">(" +
                           escape(d.noise_source.empty() ? "source not given" : d.noise_source) + ")</span>" +
                           (d.noise_urad > 0 ? "<br>" + num(d.noise_urad, 3) + " µrad per orientation coordinate " +
                                                   "<span class=\"dim\">(" + escape(d.noise_urad_source) + ")</span>"
                                             : std::string())
                     : std::string("unknown"));
  row("Base model RMS", "cal " + rms_with_ratio(d.rms.cal, noise) + " · test " +
                            (d.rms.test_nodes ? rms_with_ratio(d.rms.test, noise) : std::string("— (no test rows)")));
  row("Final RMS", "<b>cal " + rms_with_ratio(d.final_rms.cal, noise) + " · test " +
                       (d.final_rms.test_nodes || d.rms.test_nodes ? rms_with_ratio(d.final_rms.test, noise)
                                                                   : std::string("— (no test rows)")) +
                       "</b>");
  std::string accepted;
  for (const auto& a : d.accepted) accepted += (accepted.empty() ? "" : ", ") + escape(a);
  row("Accepted effects", accepted.empty() ? "none" : accepted);
  h << "</table></div>\n";
  if (!d.notes.empty()) {
    h << "<div class=\"notes\"><b>Notes</b> — what could not be done, and why:<ul>";
    for (const auto& n : d.notes) h << "<li>" << escape(n) << "</li>";
    h << "</ul></div>\n";
  }
}

// ------------------------------------------------------------ residual maps

// Magnitude colour scale shared by every map (before and after alike), so a
// tile's colour means the same number everywhere. Logarithmic when the
// errors span more than a decade and a half, which is the normal case
// (calibration shrinks them a hundredfold).
svg::Axis magnitude_scale(const Diagnosis& d) {
  svg::Range r;
  for (const auto& n : d.nodes) {
    r.add(n.before.norm());
    r.add(n.after.norm());
  }
  svg::Axis a;
  a.label = "|r| (µm)";
  if (r.empty() || !(r.hi > 0)) return a;  // [0, 1]
  // Below half the noise σ nothing is worth telling apart: the floor keeps
  // the palest colours for "at the noise level".
  double lo = std::max(r.lo, r.hi * 1e-4);
  if (finite_positive(d.noise_um) && r.hi > d.noise_um) lo = std::max(lo, 0.5 * d.noise_um);
  if (lo > 0 && r.hi / lo > 30) {
    a.log = true;
    a.lo = lo;
    a.hi = r.hi;
  } else {
    a.lo = 0;
    a.hi = r.hi;
  }
  return a;
}

struct MapFrame {
  svg::Axis x, y;
  double width = 0, height = 0;  // picture size, px
  svg::Margins margins;
};

// One x–y frame for every layer, with equal scales on x and y so the maps
// are not distorted and layers compare directly.
MapFrame map_frame(const Diagnosis& d, double tile_mm, double area_w) {
  svg::Range xr, yr;
  for (const auto& n : d.nodes)
    if (std::isfinite(n.commanded(0)) && std::isfinite(n.commanded(1))) {
      xr.add(n.commanded(0));
      yr.add(n.commanded(1));
    }
  MapFrame f;
  f.margins.left = 50;
  f.margins.right = 10;
  f.margins.top = 28;
  f.margins.bottom = 36;
  if (xr.empty()) return f;
  // Half a tile of margin, and at least 4 % so edge markers stay inside.
  const double pad = std::max(tile_mm / 2, 0.04 * std::max(xr.hi - xr.lo, yr.hi - yr.lo));
  double x0 = xr.lo - pad, x1 = xr.hi + pad;
  double y0 = yr.lo - pad, y1 = yr.hi + pad;
  if (x1 - x0 <= 0) x0 -= 1, x1 += 1;
  if (y1 - y0 <= 0) y0 -= 1, y1 += 1;
  double area_h = area_w * (y1 - y0) / (x1 - x0);
  // Keep the picture between flat and tall; widen the other range instead of
  // stretching, so a millimetre stays a millimetre in both directions.
  if (area_h > 1.3 * area_w) {
    area_h = 1.3 * area_w;
    const double need = (y1 - y0) * area_w / area_h, c = (x0 + x1) / 2;
    x0 = c - need / 2;
    x1 = c + need / 2;
  } else if (area_h < 0.6 * area_w) {
    area_h = 0.6 * area_w;
    const double need = (x1 - x0) * area_h / area_w, c = (y0 + y1) / 2;
    y0 = c - need / 2;
    y1 = c + need / 2;
  }
  f.x.lo = x0, f.x.hi = x1, f.x.label = "x (mm)";
  f.y.lo = y0, f.y.hi = y1, f.y.label = "y (mm)";
  f.width = area_w + f.margins.left + f.margins.right;
  f.height = area_h + f.margins.top + f.margins.bottom;
  return f;
}

// Tile edge: the median nearest-neighbour distance of the nodes in x–y, so a
// regular grid of nodes tiles the layer like the seed's interpolated maps.
double tile_size(const Diagnosis& d, const std::vector<std::size_t>& idx) {
  std::vector<double> nn;
  for (std::size_t a : idx) {
    double best = INFINITY;
    for (std::size_t b : idx) {
      if (a == b) continue;
      const double dist = (d.nodes[a].commanded.head<2>() - d.nodes[b].commanded.head<2>()).norm();
      if (dist > 1e-9 && dist < best) best = dist;
    }
    if (std::isfinite(best)) nn.push_back(best);
  }
  if (nn.empty()) return 0;
  std::nth_element(nn.begin(), nn.begin() + static_cast<std::ptrdiff_t>(nn.size() / 2), nn.end());
  return nn[nn.size() / 2];
}

// 1-2-5 value at or below v, for the reference arrow.
double nice_below(double v) {
  if (!finite_positive(v)) return 0;
  const double mag = std::pow(10.0, std::floor(std::log10(v)));
  const double f = v / mag;
  return (f >= 5 ? 5 : f >= 2 ? 2 : 1) * mag;
}

std::string map_panel(const Diagnosis& d, const std::vector<std::size_t>& idx, const MapFrame& frame,
                      const svg::Axis& colour, double tile_mm, bool after, const std::string& layer_name,
                      bool tooltips) {
  svg::Plot p(frame.width, frame.height, frame.margins);
  p.set_axes(frame.x, frame.y);
  std::vector<Vec3<double>> residuals;
  for (std::size_t i : idx) residuals.push_back(after ? d.nodes[i].after : d.nodes[i].before);
  p.text_px(p.left(), 14, layer_name + (after ? " · after" : " · before"), "ttl", "start");
  p.text_px(p.left(), 25, "RMS " + num(rms_per_coordinate(residuals), 3) + " µm", "val", "start");
  p.draw_axes();

  const double scale_px = (p.right() - p.left()) / (frame.x.hi - frame.x.lo);  // px per mm (equal aspect)
  const double tile_px = std::max(4.0, tile_mm * scale_px);
  double max_xy = 0;
  for (const auto& r : residuals)
    if (r.allFinite()) max_xy = std::max(max_xy, r.head<2>().norm());
  // Arrows are scaled per panel (the longest is ~0.85 tile) and a reference
  // arrow states the scale: after calibration the pattern of what is left
  // matters, and on the before scale it would be invisible. The colour, not
  // the arrow length, compares before with after.
  // Nodes on a regular grid get tiles (like the seed's interpolated maps):
  // then n tiles cover about the nodes' bounding box. Scattered nodes
  // (random poses) cover a quarter of it with isolated squares, so they get
  // coloured markers instead and the arrows a fixed length.
  svg::Range bx, by;
  for (std::size_t i : idx) bx.add(d.nodes[i].commanded(0)), by.add(d.nodes[i].commanded(1));
  const double box = bx.empty() ? 0 : std::max(bx.hi - bx.lo, tile_mm) * std::max(by.hi - by.lo, tile_mm);
  const bool tiles = tile_px >= 10 && box > 0 && static_cast<double>(idx.size()) * tile_mm * tile_mm >= 0.6 * box;
  const double arrow_len = tiles ? 0.85 * tile_px : 22.0;
  const double px_per_um = max_xy > 0 ? arrow_len / max_xy : 0;

  auto tooltip = [&](const NodeResidual& n, const Vec3<double>& r, double mag) {
    if (!tooltips) return std::string();
    return n.id + (n.test ? " (test)" : " (cal)") + ": |r| = " + num(mag, 3) + " µm (" + num(r(0), 3) + ", " +
           num(r(1), 3) + ", " + num(r(2), 3) + ")";
  };
  if (!tiles) {
    for (std::size_t k = 0; k < idx.size(); ++k) {
      const auto& n = d.nodes[idx[k]];
      const auto& r = residuals[k];
      const double x = n.commanded(0), y = n.commanded(1);
      if (p.inside(x, y) && r.allFinite() && px_per_um > 0)
        p.arrow_px(p.px(x), p.py(y), p.px(x) + r(0) * px_per_um, p.py(y) - r(1) * px_per_um, "arrow");
    }
    for (std::size_t k = 0; k < idx.size(); ++k) {
      const auto& n = d.nodes[idx[k]];
      const auto& r = residuals[k];
      const double mag = r.allFinite() ? r.norm() : std::nan("");
      const std::string fill = svg::heat_colour(colour.fraction(mag));
      if (n.test)
        p.diamond(n.commanded(0), n.commanded(1), 5.5, "mt", tooltip(n, r, mag), fill);
      else
        p.circle(n.commanded(0), n.commanded(1), 4.2, "mc", tooltip(n, r, mag), fill);
    }
  }
  for (std::size_t k = 0; k < idx.size() && tiles; ++k) {
    const auto& n = d.nodes[idx[k]];
    const auto& r = residuals[k];
    const double x = n.commanded(0), y = n.commanded(1);
    if (!p.inside(x, y)) continue;
    const double mag = r.allFinite() ? r.norm() : std::nan("");
    p.rect_px(p.px(x) - tile_px / 2, p.py(y) - tile_px / 2, tile_px, tile_px, svg::heat_colour(colour.fraction(mag)),
              false, tooltip(n, r, mag));
  }
  for (std::size_t k = 0; k < idx.size() && tiles; ++k) {
    const auto& n = d.nodes[idx[k]];
    const auto& r = residuals[k];
    const double x = n.commanded(0), y = n.commanded(1);
    if (!p.inside(x, y)) continue;
    if (r.allFinite() && px_per_um > 0)
      p.arrow_px(p.px(x), p.py(y), p.px(x) + r(0) * px_per_um, p.py(y) - r(1) * px_per_um, "arrow");
  }
  // Node markers on top of the arrows.
  std::vector<double> xs, ys;
  std::vector<bool> test, cal;
  for (std::size_t i : idx) {
    xs.push_back(d.nodes[i].commanded(0));
    ys.push_back(d.nodes[i].commanded(1));
    test.push_back(d.nodes[i].test);
    cal.push_back(!d.nodes[i].test);
  }
  if (tiles) {
    p.dots(xs, ys, cal, "nc");
    p.diamonds(xs, ys, test, 3.2, "nt");
  }
  if (px_per_um > 0) {
    const double ref = nice_below(max_xy);
    const double len = ref * px_per_um;
    const double x1 = p.right() - 4, x0 = x1 - len;
    p.arrow_px(x0, 20, x1, 20, "arrow");
    p.text_px(x0 - 4, 24, num(ref, 3) + " µm", "val", "end");
  }
  return p.str();
}

void write_maps(std::ostringstream& h, const Diagnosis& d) {
  h << "<h2 id=\"maps\">Residual maps per layer, before and after</h2>\n";
  h << "<p class=\"how\">Each node sits at its commanded x–y position. Its colour (a tile on a grid of nodes, a "
       "marker for scattered nodes) is the size of the tool-point position residual |r| (3-D, µm) on one colour "
       "scale shared by every map, before (base model) and after (with the accepted effects); the arrow is its x–y "
       "part, scaled per map (reference arrow at the top right). ● cal node (fitted), ◆ test node (held out, never "
       "fitted). Hover a node for its values.</p>\n";
  if (d.nodes.empty()) {
    h << "<p class=\"dim\">No per-node residuals in this diagnosis.</p>\n";
    return;
  }
  // Group by layer; rows without a layer form one group, projected on x–y.
  std::map<long long, std::vector<std::size_t>> layers;
  std::vector<std::size_t> no_layer;
  for (std::size_t i = 0; i < d.nodes.size(); ++i) {
    if (d.nodes[i].layer)
      layers[*d.nodes[i].layer].push_back(i);
    else
      no_layer.push_back(i);
  }
  std::vector<std::pair<std::string, std::vector<std::size_t>>> groups;
  for (auto& [layer, idx] : layers) groups.emplace_back("layer " + std::to_string(layer), std::move(idx));
  if (!no_layer.empty()) groups.emplace_back(layers.empty() ? "all nodes" : "no layer", std::move(no_layer));

  double tile_mm = 0;
  for (const auto& g : groups) {
    const double t = tile_size(d, g.second);
    if (t > 0) tile_mm = tile_mm > 0 ? std::min(tile_mm, t) : t;
  }
  svg::Range xr;
  for (const auto& n : d.nodes) xr.add(n.commanded(0)), xr.add(n.commanded(1));
  if (!(tile_mm > 0)) tile_mm = xr.empty() || xr.hi == xr.lo ? 1.0 : 0.06 * (xr.hi - xr.lo);

  // One layer: room for bigger maps; several: two layers (four maps) a row.
  const MapFrame frame = map_frame(d, tile_mm, groups.size() == 1 ? 400.0 : 240.0);
  const svg::Axis colour = magnitude_scale(d);
  const double noise_norm = finite_positive(d.noise_um) ? std::sqrt(3.0) * d.noise_um : -1;
  h << "<div class=\"panel\" style=\"display:inline-block\">"
    << svg::colour_legend(colour, 420, std::string("node colour: |r| (µm)") + (colour.log ? ", log scale" : ""),
                          noise_norm, "√3·σ")
    << "</div>\n";
  // Tooltips cost ~100 bytes a tile; past a few hundred nodes the file size
  // matters more than hovering.
  const bool tooltips = d.nodes.size() <= 400;
  if (layers.empty())
    h << "<p class=\"dim\">The data has no layer column: all nodes are shown in one x–y map.</p>\n";
  h << "<div class=\"layers\">";
  for (const auto& [name, idx] : groups) {
    std::size_t tests = 0;
    for (std::size_t i : idx) tests += d.nodes[i].test ? 1 : 0;
    h << "<div class=\"layer\"><h3>" << escape(name) << " <span class=\"dim\">(" << idx.size() - tests << " cal, "
      << tests << " test)</span></h3><div class=\"row\">";
    h << "<div class=\"panel\">" << map_panel(d, idx, frame, colour, tile_mm, false, name, tooltips) << "</div>";
    h << "<div class=\"panel\">" << map_panel(d, idx, frame, colour, tile_mm, true, name, tooltips) << "</div>";
    h << "</div></div>\n";
  }
  h << "</div>\n";
}

// ------------------------------------------------ residual against variables

// One scatter panel: values y against x for every node, cal dots filled and
// test dots hollow. `reference` > 0 draws a dashed line (the noise level).
std::string scatter_panel(const std::vector<double>& xs, const std::vector<double>& ys, const std::vector<bool>& test,
                          const std::string& title, const std::string& x_label, const std::string& y_label,
                          bool after, bool from_zero, double reference, const std::string& reference_label) {
  svg::Margins m;
  m.left = 52;
  m.right = 8;
  m.top = 22;
  m.bottom = 34;
  svg::Plot p(204, 170, m);
  svg::Range xr, yr;
  for (std::size_t i = 0; i < xs.size(); ++i)
    if (std::isfinite(xs[i]) && std::isfinite(ys[i])) xr.add(xs[i]), yr.add(ys[i]);
  if (reference > 0) yr.add(reference);
  svg::Axis xa = svg::fit_axis(xr, false, false), ya = svg::fit_axis(yr, from_zero, false);
  xa.label = x_label;
  ya.label = y_label;
  p.set_axes(xa, ya);
  p.title(title);
  p.draw_axes();
  if (!from_zero) p.hline(0, "zero");
  if (reference > 0) p.hline(reference, "noise", reference_label);
  std::vector<bool> cal(test.size());
  for (std::size_t i = 0; i < test.size(); ++i) cal[i] = !test[i];
  p.dots(xs, ys, cal, after ? "pa" : "pb");
  p.diamonds(xs, ys, test, 2.6, after ? "pat" : "pbt");
  if (xr.empty()) p.text_px((p.left() + p.right()) / 2, (p.top() + p.bottom()) / 2, "no finite data", "lbl");
  return p.str();
}

void write_joint_scatter(std::ostringstream& h, const Diagnosis& d) {
  h << "<h2 id=\"joints\">Residual against joint positions</h2>\n";
  h << "<p class=\"how\">For each actuated joint i, the joint-space residual Δq<sub>i</sub> implied by the tool "
       "residual (signed; µm, or µrad for a revolute joint) against the joint command q<sub>i</sub>; before "
       "(orange, base model) above, after (blue, accepted effects) below, each on its own vertical scale. "
       "A slope means a scale error, a sine a cyclic error, a bump a local error in part of the stroke; "
       "noise is a structureless band around zero. Filled: cal nodes; hollow diamonds: test nodes.</p>\n";
  bool any = false;
  for (const auto& n : d.nodes) any = any || !n.joint_before.isZero(0) || !n.joint_after.isZero(0);
  if (!any) {
    h << "<p class=\"dim\">No joint-space residuals in this diagnosis.</p>\n";
    return;
  }
  std::vector<bool> test;
  for (const auto& n : d.nodes) test.push_back(n.test);
  h << "<div class=\"row\">";
  for (int i = 0; i < 6; ++i) {
    std::vector<double> q, rb, ra;
    for (const auto& n : d.nodes) {
      q.push_back(joint_display(d, i, n.q(i)));
      rb.push_back(n.joint_before(i));
      ra.push_back(n.joint_after(i));
    }
    const std::string j = std::to_string(i + 1);
    const std::string xl = "q" + j + " (" + joint_unit(d, i) + ")";
    const std::string yl = "Δq" + j + " (" + joint_residual_unit(d, i) + ")";
    h << "<div class=\"panel\">" << scatter_panel(q, rb, test, "joint " + j + " · before", xl, yl, false, false, -1, {})
      << "<br>" << scatter_panel(q, ra, test, "joint " + j + " · after", xl, yl, true, false, -1, {}) << "</div>";
  }
  h << "</div>\n";
}

void write_covariates(std::ostringstream& h, const Diagnosis& d) {
  h << "<h2 id=\"covariates\">Residual against covariates</h2>\n";
  struct Cov {
    const char* name;
    const char* unit;
    std::optional<double> NodeResidual::*field;
  };
  const Cov covs[] = {{"temperature", "°C", &NodeResidual::temperature}, {"time", "s", &NodeResidual::time}};
  const double reference = finite_positive(d.noise_um) ? std::sqrt(3.0) * d.noise_um : -1;
  h << "<p class=\"how\">Size of the tool-point residual |r| (µm) against each covariate the data carries, before "
       "(orange) and after (blue). The dashed line is √3·σ, the RMS of |r| that measurement noise alone gives; "
       "a trend means the residual follows that covariate (a thermal drift follows temperature and often time).</p>\n";
  std::vector<bool> test;
  for (const auto& n : d.nodes) test.push_back(n.test);
  bool any = false;
  h << "<div class=\"row\">";
  for (const auto& c : covs) {
    std::vector<double> x, rb, ra;
    std::size_t present = 0;
    for (const auto& n : d.nodes) {
      const auto& v = n.*(c.field);
      present += v ? 1 : 0;
      x.push_back(v ? *v : std::nan(""));
      rb.push_back(n.before.norm());
      ra.push_back(n.after.norm());
    }
    if (present == 0) continue;
    any = true;
    const std::string xl = std::string(c.name) + " (" + c.unit + ")";
    h << "<div class=\"panel\">"
      << scatter_panel(x, rb, test, std::string(c.name) + " · before", xl, "|r| (µm)", false, true, reference, "√3σ")
      << "<br>"
      << scatter_panel(x, ra, test, std::string(c.name) + " · after", xl, "|r| (µm)", true, true, reference, "√3σ")
      << "</div>";
  }
  h << "</div>\n";
  if (!any) h << "<p class=\"dim\">The data carries no temperature or time column.</p>\n";
}

// ------------------------------------------------------------------ groups

void write_group_table(std::ostringstream& h, const std::string& title, const std::vector<ResidualGroup>& groups,
                       double noise) {
  h << "<h3>" << escape(title) << "</h3>\n";
  if (groups.empty()) {
    h << "<p class=\"dim\">none</p>\n";
    return;
  }
  // Bars show the ratio to the noise, not the RMS: the joint rows mix µm and
  // µrad, each against its own noise level, and the ratio reads the same in
  // every table (the dashed line at 1 is "at the noise level").
  std::vector<double> ratios;
  svg::Range r;
  r.add(1.0);
  for (const auto& g : groups) {
    const double ratio = std::isfinite(g.ratio) && g.ratio != 0 ? g.ratio
                         : finite_positive(noise) && std::isfinite(g.rms_um) ? g.rms_um / noise
                                                                             : std::nan("");
    ratios.push_back(ratio);
    r.add(ratio);
  }
  // One scale per table, logarithmic when a hot group would otherwise
  // squash the others to nothing.
  svg::Axis a;
  a.lo = 0;
  a.hi = r.hi * 1.05;
  if (r.hi > 30) {
    a.log = true;
    a.lo = std::max(0.1, std::min(0.5, r.lo)) / 1.5;
    a.hi = r.hi * 1.1;
  }
  h << "<table class=\"t\"><tr><th>group</th><th>nodes</th><th>RMS</th><th>× noise</th><th>RMS / noise"
    << (a.log ? " (log scale)" : "") << "; dashed: 1</th></tr>";
  for (std::size_t k = 0; k < groups.size(); ++k) {
    const auto& g = groups[k];
    const double ratio = ratios[k];
    const char* cls = !std::isfinite(ratio) ? "mid" : ratio <= 1.5 ? "ok" : ratio <= 3 ? "mid" : "bad";
    const double w = std::isfinite(ratio) ? std::clamp(a.fraction(ratio), 0.0, 1.0) * 100 : 0;
    h << "<tr><td class=\"l\">" << escape(g.label) << "</td><td>" << g.nodes << "</td><td>" << num(g.rms_um, 3)
      << "</td><td>" << num(ratio, 3) << "</td><td><div class=\"bar\"><i class=\"" << cls << "\" style=\"width:"
      << fixed(w, 1) << "%\"></i><b style=\"left:" << fixed(std::clamp(a.fraction(1.0), 0.0, 1.0) * 100, 1)
      << "%\"></b></div></td></tr>";
  }
  h << "</table>\n";
}

void write_groups(std::ostringstream& h, const Diagnosis& d) {
  h << "<h2 id=\"groups\">Residual left by the final model, by group</h2>\n";
  h << "<p class=\"how\">What the final model (base + accepted effects) leaves, grouped. RMS is per measured "
       "coordinate in µm; for the joints it is the implied joint-space residual in the unit of the label, against "
       "that joint's own noise level; for a covariate it is the part of the residual that follows the covariate "
       "linearly. The bar is the ratio to the noise: green within 1.5×, orange up to 3×, red above. A group well "
       "above 1 points at where the model still fails.</p>\n<div class=\"row\">";
  const std::pair<const char*, const std::vector<ResidualGroup>*> tables[] = {
      {"by layer", &d.by_layer}, {"by joint", &d.by_joint}, {"by workspace region", &d.by_region},
      {"by covariate", &d.by_covariate}};
  for (const auto& [title, groups] : tables) {
    h << "<div>";
    write_group_table(h, title, *groups, d.noise_um);
    h << "</div>";
  }
  h << "</div>\n";
}

// ----------------------------------------------------------------- ranking

// A p-value that underflowed to 0 is "too small to compute", not zero.
std::string p_text(double p) { return p == 0 ? "≈ 0" : num(p, 2); }

void write_ranking(std::ostringstream& h, const Diagnosis& d) {
  h << "<h2 id=\"ranking\">Candidate effects</h2>\n";
  h << "<p class=\"how\">Each candidate is tested for what it adds beyond the fitted model: its columns are "
       "orthogonalised against the model, F is the test statistic of the added columns, p its raw and "
       "Holm-adjusted (family-wise) significance, “confounded” the share of the effect's column energy the "
       "model already explains. RMS after: model + this effect refitted on the cal rows; held-out gain: the "
       "relative fall of the test-row RMS. An effect is accepted when significant and it helps the held-out "
       "rows.</p>\n";
  if (d.ranking.empty()) {
    h << "<p class=\"dim\">No candidate effect was tested.</p>\n";
    return;
  }
  h << "<table class=\"t\"><tr><th>effect</th><th>step</th><th>param.</th><th>F</th><th>p raw</th>"
       "<th>p Holm</th><th>confounded</th><th>RMS after cal (µm)</th><th>RMS after test (µm)</th>"
       "<th>held-out gain</th><th>accepted</th></tr>";
  for (const auto& e : d.ranking) {
    if (!e.testable) {
      h << "<tr class=\"nt\"><td class=\"l\">" << escape(e.effect) << "</td><td colspan=\"10\" class=\"l\">not "
        << "testable: " << escape(e.why_not.empty() ? "reason not given" : e.why_not) << "</td></tr>";
      continue;
    }
    h << "<tr" << (e.accepted ? " class=\"acc\"" : "") << "><td class=\"l\"><b>" << escape(e.effect) << "</b></td><td>"
      << (e.step > 0 ? std::to_string(e.step) : std::string("—")) << "</td><td>" << e.parameters << "</td><td>"
      << num(e.score, 3) << "</td><td>" << p_text(e.p_value) << "</td><td>" << p_text(e.p_adjusted) << "</td><td>"
      << fixed(100 * e.confounded, 1) << " %</td><td>" << num(e.rms_after.cal, 3) << "</td><td>"
      << (e.rms_after.test_nodes || d.rms.test_nodes ? num(e.rms_after.test, 3) : std::string("—")) << "</td><td>"
      << (d.rms.test_nodes ? fixed(100 * e.test_gain, 1) + " %" : std::string("—")) << "</td><td>"
      << (e.accepted ? "✓ yes" : "no") << "</td></tr>";
  }
  h << "</table>\n";
  for (const auto& e : d.ranking)
    if (e.plan_confounded >= 0)
      h << "<p><b>" << escape(e.effect) << "</b> is " << fixed(100 * e.confounded, 1)
        << " % confounded with the model on these poses: the data can hardly tell it from the base. "
        << (e.plan_confounded < 0.9 ? "Poses planned for it" : "A plan for it") << " (<code>kincal plan --effects "
        << escape(e.plan_effects) << " --count " << e.plan_count << "</code>, docs/plan.md) "
        << (e.plan_confounded < 0.9 ? "bring that to about " : "still leaves about ") << fixed(100 * e.plan_confounded, 1)
        << (e.plan_confounded < 0.9 ? " %." : " %: the workspace hardly separates it.") << "</p>\n";
}

// ------------------------------------------------------------------- steps

void write_steps(std::ostringstream& h, const Diagnosis& d) {
  h << "<h2 id=\"steps\">The error falling, step by step</h2>\n";
  h << "<p class=\"how\">RMS residual per coordinate after each step of the stepwise search: the base model, then "
       "one accepted effect added per step. Blue: cal rows (fitted); orange: test rows (held out). The dashed "
       "line is the noise σ, where the residual should end.</p>\n";
  if (d.steps.empty()) {
    h << "<p class=\"dim\">No steps recorded.</p>\n";
    return;
  }
  const bool with_test = d.rms.test_nodes > 0 || std::any_of(d.steps.begin(), d.steps.end(), [](const auto& s) {
                           return s.rms.test_nodes > 0;
                         });
  svg::Range r;
  for (const auto& s : d.steps) {
    r.add(s.rms.cal);
    if (with_test) r.add(s.rms.test);
  }
  if (finite_positive(d.noise_um)) r.add(d.noise_um);
  svg::Axis ya = svg::fit_axis(r, true, true, 10);
  if (ya.log) ya.lo = std::min(ya.lo, r.lo / 1.5);
  ya.label = "RMS (µm)";
  const double slot = 120;
  svg::Margins m;
  m.left = 60;
  m.bottom = 46;
  m.top = 30;
  const double width = std::max(420.0, m.left + m.right + slot * static_cast<double>(d.steps.size()));
  svg::Plot p(width, 300, m);
  svg::Axis xa;
  xa.lo = 0;
  xa.hi = static_cast<double>(d.steps.size());
  p.set_axes(xa, ya);
  p.draw_axes(false);
  // The noise line goes under the bars and its label into the legend: the
  // last bars end right at it when all is well, with their value labels.
  if (finite_positive(d.noise_um)) p.hline(d.noise_um, "noise");
  const double base_y = p.bottom();
  for (std::size_t k = 0; k < d.steps.size(); ++k) {
    const auto& s = d.steps[k];
    const double cx = p.px(static_cast<double>(k) + 0.5);
    const double bw = with_test ? 30 : 44;
    auto bar = [&](double x, double v, const char* cls) {
      if (!std::isfinite(v)) return;
      const double y = std::min(base_y, p.py(v));
      p.rect_px(x, y, bw, base_y - y, cls, true, num(v, 3) + " µm");
      p.text_px(x + bw / 2, y - 3, num(v, 3), "val");
    };
    if (with_test) {
      bar(cx - bw - 2, s.rms.cal, "bc");
      bar(cx + 2, s.rms.test, "bt");
    } else {
      bar(cx - bw / 2, s.rms.cal, "bc");
    }
    std::string label = s.model.empty() ? "step " + std::to_string(k) : s.model.back();
    if (k > 0 && !s.model.empty()) label = "+ " + label;
    p.text_px(cx, p.bottom() + 14, label, "lbl");
    if (s.model.size() > 2) {  // the whole model once it is more than "base + one"
      std::string model;
      for (const auto& e : s.model) model += (model.empty() ? "" : " + ") + e;
      p.text_px(cx, p.bottom() + 27, model.size() > 24 ? model.substr(0, 22) + "…" : model, "tick");
    }
  }
  p.rect_px(p.left() + 8, 9, 10, 10, "bc");
  p.text_px(p.left() + 22, 18, "cal", "lbl", "start");
  double lx = p.left() + 52;
  if (with_test) {
    p.rect_px(lx, 9, 10, 10, "bt");
    p.text_px(lx + 14, 18, "test (held out)", "lbl", "start");
    lx += 104;
  }
  if (finite_positive(d.noise_um)) {
    p.line_px(lx, 14, lx + 22, 14, "noise");
    p.text_px(lx + 26, 18, "noise σ = " + num(d.noise_um, 3) + " µm", "lbl", "start");
  }
  h << "<div class=\"panel\" style=\"display:inline-block\">" << p.str() << "</div>\n";
}

// ---------------------------------------------------------------- hotspots

void write_hotspots(std::ostringstream& h, const Diagnosis& d) {
  if (d.verdict != "unexplained" && d.hotspots.empty()) return;
  h << "<h2 id=\"hotspots\">Hotspots: where the unexplained residual concentrates</h2>\n";
  if (d.hotspots.empty()) {
    h << "<p class=\"dim\">No hotspot could be located: the remaining residual is spread evenly.</p>\n";
    return;
  }
  h << "<p class=\"how\">Share: the fraction of the residual energy above the noise found there. Look here first "
       "for the physical effect the model is missing.</p>\n<ol class=\"hot\">";
  for (const auto& s : d.hotspots) {
    h << "<li><span class=\"kind\">" << escape(s.kind) << "</span> <b>" << escape(s.where) << "</b> — "
      << fixed(100 * s.share, 1) << " % of the excess";
    if (!s.detail.empty()) h << "; " << escape(s.detail);
    h << "</li>";
  }
  h << "</ol>\n";
}

}  // namespace

std::string diagnosis_report_html(const Diagnosis& d) {
  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n"
    << "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
    << "<title>kincal diagnosis — " << escape(d.robot.empty() ? "report" : d.robot) << "</title>\n<style>" << kStyle
    << "</style></head>\n<body>" << svg::shared_defs() << "<main>\n";
  write_header(h, d);
  h << "<p class=\"dim\">Sections: <a href=\"#maps\">maps</a> · <a href=\"#joints\">joints</a> · "
       "<a href=\"#covariates\">covariates</a> · <a href=\"#groups\">groups</a> · <a href=\"#ranking\">effects</a> · "
       "<a href=\"#steps\">steps</a>"
    << (d.verdict == "unexplained" || !d.hotspots.empty() ? " · <a href=\"#hotspots\">hotspots</a>" : "")
    << "</p>\n";
  write_hotspots(h, d);
  write_steps(h, d);
  write_ranking(h, d);
  write_maps(h, d);
  write_joint_scatter(h, d);
  write_covariates(h, d);
  write_groups(h, d);
  h << "<footer>kincal " << kVersion << " · diagnosis in " << num(d.seconds, 3)
    << " s · self-contained report: inline SVG and CSS, no script, no external resource.</footer>\n";
  h << "</main></body></html>\n";
  return h.str();
}

}  // namespace kincal::identify
