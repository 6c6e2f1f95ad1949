#include <algorithm>
#include <cmath>
#include <fstream>

#include <fmt/format.h>

#include "report.h"

namespace plx::cli {

std::string htmlEscape(const std::string& text) {
    std::string out;
    for (char c : text) {
        switch (c) {
            case '<': out += "&lt;"; break;
            case '>': out += "&gt;"; break;
            case '&': out += "&amp;"; break;
            case '"': out += "&quot;"; break;
            default: out += c;
        }
    }
    return out;
}

namespace {

// "Nice" tick step (1, 2 or 5 times a power of ten) giving about `count` ticks over a range.
double niceStep(double range, int count) {
    double raw = range / std::max(count, 1);
    double mag = std::pow(10.0, std::floor(std::log10(raw)));
    for (double m : {1.0, 2.0, 5.0, 10.0})
        if (raw <= m * mag) return m * mag;
    return 10.0 * mag;
}

std::string tickLabel(double v) {
    double a = std::fabs(v);
    if (a >= 1e6) return fmt::format("{:g}M", v / 1e6);
    if (a >= 1e3) return fmt::format("{:g}k", v / 1e3);
    return fmt::format("{:g}", v);
}

constexpr const char* kColors[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd",
                                   "#8c564b", "#e377c2", "#17becf"};

}  // namespace

std::string svgLinePlot(const PlotSpec& spec, const std::vector<PlotSeries>& series) {
    const double w = 560, h = 340, left = 70, right = 20, top = 36, bottom = 56;
    double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
    for (const auto& s : series) {
        for (auto [x, y] : s.points) {
            if (!std::isfinite(x) || !std::isfinite(y) || (spec.logX && x <= 0)) continue;
            double xv = spec.logX ? std::log10(x) : x;
            x0 = std::min(x0, xv), x1 = std::max(x1, xv);
            y0 = std::min(y0, y), y1 = std::max(y1, y);
        }
    }
    if (!(x0 <= x1)) x0 = 0, x1 = 1, y0 = 0, y1 = 1;
    if (spec.yFromZero) y0 = std::min(y0, 0.0);
    if (x1 - x0 < 1e-12) x1 = x0 + 1;
    if (y1 - y0 < 1e-12) y1 = y0 + 1;
    y1 += 0.05 * (y1 - y0);
    auto px = [&](double x) { return left + ((spec.logX ? std::log10(x) : x) - x0) / (x1 - x0) * (w - left - right); };
    auto py = [&](double y) { return top + (1.0 - (y - y0) / (y1 - y0)) * (h - top - bottom); };

    std::string svg = fmt::format(
        "<svg xmlns='http://www.w3.org/2000/svg' width='{}' height='{}' font-family='sans-serif' "
        "font-size='12'><rect width='100%' height='100%' fill='white'/>",
        w, h);
    svg += fmt::format("<text x='{}' y='20' text-anchor='middle' font-size='14' "
                       "font-weight='bold'>{}</text>",
                       w / 2, htmlEscape(spec.title));
    // Axes and ticks.
    svg += fmt::format("<line x1='{0}' y1='{1}' x2='{2}' y2='{1}' stroke='black'/>", left,
                       h - bottom, w - right);
    svg += fmt::format("<line x1='{0}' y1='{1}' x2='{0}' y2='{2}' stroke='black'/>", left, top,
                       h - bottom);
    double ys = niceStep(y1 - y0, 5);
    for (double y = std::ceil(y0 / ys) * ys; y <= y1 + 1e-9; y += ys) {
        svg += fmt::format("<line x1='{0}' y1='{1:.1f}' x2='{2}' y2='{1:.1f}' stroke='#ddd'/>"
                           "<text x='{3}' y='{4:.1f}' text-anchor='end'>{5}</text>",
                           left, py(y), w - right, left - 6, py(y) + 4, tickLabel(y));
    }
    if (spec.logX) {
        for (double e = std::floor(x0); e <= x1 + 1e-9; e += 1.0) {
            double x = std::pow(10.0, e);
            if (e < x0 - 1e-9) continue;
            svg += fmt::format("<text x='{:.1f}' y='{}' text-anchor='middle'>{}</text>", px(x),
                               h - bottom + 16, tickLabel(x));
        }
    } else {
        double xs = niceStep(x1 - x0, 6);
        for (double x = std::ceil(x0 / xs) * xs; x <= x1 + 1e-9; x += xs)
            svg += fmt::format("<text x='{:.1f}' y='{}' text-anchor='middle'>{}</text>", px(x),
                               h - bottom + 16, tickLabel(x));
    }
    svg += fmt::format("<text x='{}' y='{}' text-anchor='middle'>{}</text>", (left + w - right) / 2,
                       h - 14, htmlEscape(spec.xLabel));
    svg += fmt::format("<text transform='translate(16,{}) rotate(-90)' text-anchor='middle'>{}"
                       "</text>",
                       (top + h - bottom) / 2, htmlEscape(spec.yLabel));
    // Series: polyline, markers, legend.
    for (size_t i = 0; i < series.size(); ++i) {
        const char* color = kColors[i % std::size(kColors)];
        std::string pts;
        for (auto [x, y] : series[i].points) {
            if (!std::isfinite(x) || !std::isfinite(y) || (spec.logX && x <= 0)) continue;
            pts += fmt::format("{:.1f},{:.1f} ", px(x), py(y));
            svg += fmt::format("<circle cx='{:.1f}' cy='{:.1f}' r='3' fill='{}'/>", px(x), py(y),
                               color);
        }
        svg += fmt::format("<polyline points='{}' fill='none' stroke='{}' stroke-width='2'/>", pts,
                           color);
        double ly = top + 8 + 16 * double(i);
        svg += fmt::format("<rect x='{}' y='{}' width='12' height='3' fill='{}'/><text x='{}' "
                           "y='{}'>{}</text>",
                           left + 12, ly, color, left + 28, ly + 5, htmlEscape(series[i].name));
    }
    svg += "</svg>";
    return svg;
}

HtmlReport::HtmlReport(std::string title) : mTitle(std::move(title)) {}

void HtmlReport::heading(const std::string& text, int level) {
    mBody += fmt::format("<h{0}>{1}</h{0}>\n", level, htmlEscape(text));
}

void HtmlReport::paragraph(const std::string& html) { mBody += "<p>" + html + "</p>\n"; }

void HtmlReport::images(const std::vector<std::pair<std::string, std::string>>& items) {
    mBody += "<div class='row'>";
    for (const auto& [path, caption] : items)
        mBody += fmt::format("<figure><a href='{0}'><img src='{0}' alt='{1}'></a><figcaption>{1}"
                             "</figcaption></figure>",
                             htmlEscape(path), htmlEscape(caption));
    mBody += "</div>\n";
}

void HtmlReport::table(const std::vector<std::string>& header,
                       const std::vector<std::vector<std::string>>& rows) {
    mBody += "<table><tr>";
    for (const auto& h : header) mBody += "<th>" + htmlEscape(h) + "</th>";
    mBody += "</tr>\n";
    for (const auto& row : rows) {
        mBody += "<tr>";
        for (const auto& cell : row) mBody += "<td>" + htmlEscape(cell) + "</td>";
        mBody += "</tr>\n";
    }
    mBody += "</table>\n";
}

void HtmlReport::raw(const std::string& html) { mBody += html + "\n"; }

Status HtmlReport::write(const std::string& path) const {
    std::ofstream out(path, std::ios::trunc);
    if (!out) return errorStatus(ErrorCode::kIoError, fmt::format("cannot create '{}'", path));
    out << "<!doctype html>\n<html><head><meta charset='utf-8'><title>" << htmlEscape(mTitle)
        << "</title>\n<style>body{font-family:sans-serif;max-width:1200px;margin:2em auto;"
           "padding:0 1em;color:#222}figure{display:inline-block;margin:0 12px 12px 0}"
           "img{max-width:380px;border:1px solid #ccc;image-rendering:pixelated}"
           "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;"
           "padding:3px 8px;text-align:right}th{background:#f3f3f3}.row{display:flex;"
           "flex-wrap:wrap}</style></head><body>\n<h1>"
        << htmlEscape(mTitle) << "</h1>\n"
        << mBody << "</body></html>\n";
    out.close();
    if (!out) return errorStatus(ErrorCode::kIoError, fmt::format("cannot write '{}'", path));
    return Status::ok();
}

}  // namespace plx::cli
