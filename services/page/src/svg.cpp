#include "tandem/page/svg.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace tandem::page {
namespace {
const char* kPalette[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b",
                          "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};

std::string num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f", v);
  return b;
}
std::string tick_text(double v) {
  char b[32];
  if (v != 0.0 && (std::fabs(v) >= 1e5 || std::fabs(v) < 1e-3)) {
    std::snprintf(b, sizeof b, "%.3g", v);  // 1.5e-07, not 2e-07 (two ticks must not read alike)
  } else {
    std::snprintf(b, sizeof b, "%g", v);
  }
  return b;
}
}  // namespace

std::string xml_escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
      case '<': o += "&lt;"; break;
      case '>': o += "&gt;"; break;
      case '&': o += "&amp;"; break;
      case '"': o += "&quot;"; break;
      default: o += c;
    }
  }
  return o;
}

std::vector<double> nice_ticks(double lo, double hi, int n) {
  std::vector<double> t;
  if (!(hi > lo)) {
    t.push_back(lo);
    return t;
  }
  const double raw = (hi - lo) / std::max(1, n);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 2.5, 5.0, 10.0}) {
    if (mag * m >= raw) {
      step = mag * m;
      break;
    }
  }
  for (double v = std::ceil(lo / step) * step; v <= hi + 1e-9 * step; v += step) t.push_back(std::fabs(v) < 1e-12 * step ? 0.0 : v);
  return t;
}

std::string render_svg(const Plot& p, int width, int height) {
  // Margins (legend on the right; room below for slanted category names).
  // Room on the left for the longest y label (about 6 px a character at font-size 10).
  size_t ylabel_chars = 0;
  for (const std::string& c : p.ycategories) ylabel_chars = std::max(ylabel_chars, c.size());
  const double L = std::max(p.xcategories.empty() ? 70.0 : 120.0, 16.0 + 6.0 * static_cast<double>(ylabel_chars)), R = 170,
               T = 34, B = p.xcategories.empty() ? 46 : 150;
  const double W = width - L - R, H = height - T - B;
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  auto ty = [&](double y) { return p.log_y ? std::log10(std::max(y, 1e-12)) : y; };
  for (const Series& s : p.series) {
    for (const auto& [x, y] : s.xy) {
      if (!std::isfinite(x) || !std::isfinite(y)) continue;
      x0 = std::min(x0, x);
      x1 = std::max(x1, x);
      y0 = std::min(y0, ty(y));
      y1 = std::max(y1, ty(y));
    }
  }
  for (const RefLine& h : p.hlines) {
    y0 = std::min(y0, ty(h.value));
    y1 = std::max(y1, ty(h.value));
  }
  if (p.ymax_hint > p.ymin_hint) {
    y0 = std::min(y0, ty(p.ymin_hint));
    y1 = std::max(y1, ty(p.ymax_hint));
  }
  if (!p.xcategories.empty()) {
    x0 = -0.5;
    x1 = static_cast<double>(p.xcategories.size()) - 0.5;
  }
  if (!p.ycategories.empty()) {
    y0 = -0.5;
    y1 = static_cast<double>(p.ycategories.size()) - 0.5;
  }
  if (x0 > x1) x0 = 0, x1 = 1;
  if (y0 > y1) y0 = 0, y1 = 1;
  if (x1 - x0 < 1e-12) x1 = x0 + 1;
  if (y1 - y0 < 1e-12) {
    y0 -= 0.5;
    y1 += 0.5;
  } else if (p.ycategories.empty()) {
    const double pad = 0.05 * (y1 - y0);
    y0 -= pad;
    y1 += pad;
  }
  auto X = [&](double x) { return L + (x - x0) / (x1 - x0) * W; };
  auto Y = [&](double y) { return T + H - (ty(y) - y0) / (y1 - y0) * H; };
  auto Yraw = [&](double yt) { return T + H - (yt - y0) / (y1 - y0) * H; };

  std::ostringstream o;
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\"" << height
    << "\" viewBox=\"0 0 " << width << " " << height << "\" font-family=\"sans-serif\" font-size=\"12\">\n";
  o << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  o << "<text x=\"" << L << "\" y=\"20\" font-size=\"15\" font-weight=\"bold\">" << xml_escape(p.title) << "</text>\n";
  o << "<rect x=\"" << L << "\" y=\"" << T << "\" width=\"" << W << "\" height=\"" << H
    << "\" fill=\"none\" stroke=\"#444\"/>\n";
  // Axes ticks and grid.
  if (p.xcategories.empty()) {
    for (double t : nice_ticks(x0, x1, 8)) {
      o << "<line x1=\"" << num(X(t)) << "\" y1=\"" << T << "\" x2=\"" << num(X(t)) << "\" y2=\"" << T + H
        << "\" stroke=\"#eee\"/><text x=\"" << num(X(t)) << "\" y=\"" << T + H + 16 << "\" text-anchor=\"middle\">"
        << tick_text(t) << "</text>\n";
    }
  } else {
    for (size_t i = 0; i < p.xcategories.size(); ++i) {
      o << "<text transform=\"translate(" << num(X(static_cast<double>(i)) + 4) << "," << T + H + 12
        << ") rotate(-30)\" text-anchor=\"end\" font-size=\"11\">" << xml_escape(p.xcategories[i]) << "</text>\n";
    }
  }
  if (p.ycategories.empty()) {
    std::vector<double> ticks = nice_ticks(y0, y1, 6);
    for (double t : ticks) {
      const double v = p.log_y ? std::pow(10.0, t) : t;
      if (p.log_y && std::fabs(t - std::round(t)) > 1e-9) continue;
      o << "<line x1=\"" << L << "\" y1=\"" << num(Yraw(t)) << "\" x2=\"" << L + W << "\" y2=\"" << num(Yraw(t))
        << "\" stroke=\"#eee\"/><text x=\"" << L - 6 << "\" y=\"" << num(Yraw(t) + 4) << "\" text-anchor=\"end\">"
        << tick_text(v) << "</text>\n";
    }
  } else {
    for (size_t i = 0; i < p.ycategories.size(); ++i) {
      const double y = Yraw(static_cast<double>(i));
      o << "<line x1=\"" << L << "\" y1=\"" << num(y) << "\" x2=\"" << L + W << "\" y2=\"" << num(y)
        << "\" stroke=\"#eee\"/><text x=\"" << L - 6 << "\" y=\"" << num(y + 4) << "\" text-anchor=\"end\" font-size=\"10\">"
        << xml_escape(p.ycategories[i]) << "</text>\n";
    }
  }
  o << "<text x=\"" << L + W / 2 << "\" y=\"" << height - 8 << "\" text-anchor=\"middle\">" << xml_escape(p.xlabel)
    << "</text>\n";
  o << "<text transform=\"translate(16," << T + H / 2 << ") rotate(-90)\" text-anchor=\"middle\">"
    << xml_escape(p.ylabel) << "</text>\n";
  for (const RefLine& m : p.markers) {
    if (m.value < x0 || m.value > x1) continue;
    o << "<line x1=\"" << num(X(m.value)) << "\" y1=\"" << T << "\" x2=\"" << num(X(m.value)) << "\" y2=\"" << T + H
      << "\" stroke=\"" << m.color << "\" stroke-opacity=\"0.35\"><title>" << xml_escape(m.label) << "</title></line>\n";
  }
  for (const RefLine& h : p.hlines) {
    o << "<line x1=\"" << L << "\" y1=\"" << num(Y(h.value)) << "\" x2=\"" << L + W << "\" y2=\"" << num(Y(h.value))
      << "\" stroke=\"" << h.color << "\" stroke-dasharray=\"6,4\"/>"
      << "<text x=\"" << L + W - 4 << "\" y=\"" << num(Y(h.value) - 4) << "\" text-anchor=\"end\" fill=\"" << h.color
      << "\">" << xml_escape(h.label) << "</text>\n";
  }
  o << "<clipPath id=\"c\"><rect x=\"" << L << "\" y=\"" << T << "\" width=\"" << W << "\" height=\"" << H
    << "\"/></clipPath>\n<g clip-path=\"url(#c)\">\n";
  for (size_t si = 0; si < p.series.size(); ++si) {
    const Series& s = p.series[si];
    const std::string color = s.color.empty() ? kPalette[si % 10] : s.color;
    if (s.style == Series::Style::Points) {
      for (const auto& [x, y] : s.xy) {
        if (!std::isfinite(x) || !std::isfinite(y)) continue;
        o << "<circle cx=\"" << num(X(x)) << "\" cy=\"" << num(Y(y)) << "\" r=\"3\" fill=\"" << color
          << "\" fill-opacity=\"0.7\"/>";
      }
      o << "\n";
      continue;
    }
    o << "<polyline fill=\"none\" stroke=\"" << color << "\" stroke-width=\"1.3\" points=\"";
    bool first = true;
    double prev_y = 0;
    for (const auto& [x, y] : s.xy) {
      if (!std::isfinite(x) || !std::isfinite(y)) continue;
      if (s.style == Series::Style::Step && !first) o << num(X(x)) << "," << num(Y(prev_y)) << " ";
      o << num(X(x)) << "," << num(Y(y)) << " ";
      prev_y = y;
      first = false;
    }
    o << "\"/>\n";
  }
  o << "</g>\n";
  // Legend.
  for (size_t si = 0; si < p.series.size() && si < 16; ++si) {
    const Series& s = p.series[si];
    const std::string color = s.color.empty() ? kPalette[si % 10] : s.color;
    const double y = T + 10 + 16 * static_cast<double>(si);
    o << "<rect x=\"" << L + W + 12 << "\" y=\"" << y - 8 << "\" width=\"12\" height=\"8\" fill=\"" << color
      << "\"/><text x=\"" << L + W + 30 << "\" y=\"" << y << "\">" << xml_escape(s.name) << "</text>\n";
  }
  o << "</svg>\n";
  return o.str();
}

}  // namespace tandem::page
