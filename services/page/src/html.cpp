#include "tandem/page/html.hpp"

#include "tandem/page/svg.hpp"

namespace tandem::page {

const std::string& style_css() {
  static const std::string css =
#include "tandem/page/style_css.inc"
      ;
  return css;
}

std::string html_head(const std::string& title, const std::string& extra_css) {
  return "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>" + xml_escape(title) +
         "</title>\n<style>\n" + style_css() + extra_css + "</style></head><body>\n";
}

std::string header_bar(const std::string& title, const std::string& status_html) {
  return "<header><h1>" + xml_escape(title) + "</h1>" + status_html + "</header>\n";
}

}  // namespace tandem::page
