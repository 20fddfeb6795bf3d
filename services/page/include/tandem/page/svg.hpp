// A small SVG plot writer (line, step and point series, horizontal reference lines, vertical markers,
// categorical axes) for the soak report and other reports of the project. No dependencies.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace tandem::page {

struct Series {
  std::string name;
  std::vector<std::pair<double, double>> xy;
  std::string color;        ///< "" = from the palette
  enum class Style { Line, Step, Points } style = Style::Line;
};

struct RefLine {
  double value = 0.0;
  std::string label;
  std::string color = "#c0392b";
};

struct Plot {
  std::string title, xlabel, ylabel;
  std::vector<Series> series;
  std::vector<RefLine> hlines;   ///< horizontal lines at y values
  std::vector<RefLine> markers;  ///< vertical lines at x values (faults, events)
  std::vector<std::string> ycategories;  ///< if set: y values are indices into these names
  std::vector<std::string> xcategories;  ///< if set: x values are indices into these names
  bool log_y = false;
  double ymin_hint = 0.0, ymax_hint = 0.0;  ///< included in the y range when ymax_hint > ymin_hint
};

/// The plot as a standalone SVG document.
std::string render_svg(const Plot& p, int width = 960, int height = 340);

/// "Nice" axis ticks covering [lo, hi] (about n of them).
std::vector<double> nice_ticks(double lo, double hi, int n = 6);

/// Text escaped for XML.
std::string xml_escape(const std::string& s);

}  // namespace tandem::page
