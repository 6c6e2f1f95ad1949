#pragma once
// The demo's HTML report: headings, text, image rows, tables and inline SVG line plots. No
// scripts and no network: one self-contained page next to its PNG files.

#include <string>
#include <utility>
#include <vector>

#include <plx/core/status.h>

namespace plx::cli {

struct PlotSeries {
    std::string name;
    std::vector<std::pair<double, double>> points;  // (x, y)
};

struct PlotSpec {
    std::string title, xLabel, yLabel;
    bool logX = false;
    bool yFromZero = true;
};

// An SVG line plot with axes, ticks, markers and a legend.
std::string svgLinePlot(const PlotSpec& spec, const std::vector<PlotSeries>& series);

class HtmlReport {
public:
    explicit HtmlReport(std::string title);

    void heading(const std::string& text, int level = 2);
    void paragraph(const std::string& html);
    // A row of images with captions; paths are relative to the report's folder.
    void images(const std::vector<std::pair<std::string, std::string>>& pathAndCaption);
    void table(const std::vector<std::string>& header,
               const std::vector<std::vector<std::string>>& rows);
    void raw(const std::string& html);

    Status write(const std::string& path) const;

private:
    std::string mTitle;
    std::string mBody;
};

std::string htmlEscape(const std::string& text);

}  // namespace plx::cli
