// The start of the project's HTML pages (the soak's report, the recording's report): the shared stylesheet
// (services/page/style.css, also the live view's /style.css) embedded, so that a report stays a single file, and
// the header bar the live view has.
#pragma once

#include <string>

namespace tandem::page {

/// The shared stylesheet (services/page/style.css).
const std::string& style_css();

/// "<!doctype html>...<body>": the title (escaped) and the stylesheet inline, plus `extra_css` for the page's own.
std::string html_head(const std::string& title, const std::string& extra_css = "");

/// The header bar: the title (escaped) and, after it, `status_html` as it is (a verdict, a subtitle).
std::string header_bar(const std::string& title, const std::string& status_html = "");

}  // namespace tandem::page
