// The rear-surface hole fill (holes.h; Mark, Bishop, McMillan, "Improving Quality of Final
// Images").

#include <cstring>
#include <vector>

#include <plx/warp/holes.h>

namespace plx::warp {

int fillRowRearSurface(Rgba8* c, float* d, uint8_t* m, int w) {
    int filled = 0;
    bool anyCovered = false;
    int x = 0;
    while (x < w) {
        if (m[x] != 1) {
            // Jump to the next hole (memchr is vectorised; most of a row is covered).
            anyCovered = true;
            const void* next = std::memchr(m + x, 1, size_t(w - x));
            x = next ? int(static_cast<const uint8_t*>(next) - m) : w;
            continue;
        }
        int end = x;
        while (end < w && m[end] == 1) ++end;
        // The run [x, end): its ends' covered neighbours; the farther one is the rear surface.
        int src = -1;
        if (x > 0 && end < w)
            src = d[x - 1] <= d[end] ? x - 1 : end;
        else if (x > 0)
            src = x - 1;
        else if (end < w)
            src = end;
        if (src >= 0) {
            for (int i = x; i < end; ++i) {
                c[i] = c[src];
                d[i] = d[src];
                m[i] = 2;
            }
            filled += end - x;
        }
        x = end;
    }
    return anyCovered ? filled : -1;
}

int64_t fillEmptyRows(Image<Rgba8>* color, Image<float>* depth, Image<uint8_t>* holeMask,
                      Rgba8 clearColor) {
    const int w = color->width(), h = color->height();
    int64_t filled = 0;
    for (int y = 0; y < h; ++y) {
        if (w == 0 || holeMask->at(0, y) != 1) continue;  // a covered or filled row
        int src = -1;
        for (int dy = 1; dy < h && src < 0; ++dy) {
            if (y - dy >= 0 && holeMask->at(0, y - dy) != 1)
                src = y - dy;
            else if (y + dy < h && holeMask->at(0, y + dy) != 1)
                src = y + dy;
        }
        for (int x = 0; x < w; ++x) {
            color->at(x, y) = src >= 0 ? color->at(x, src) : clearColor;
            depth->at(x, y) = src >= 0 ? depth->at(x, src) : 0.0f;
            holeMask->at(x, y) = 2;
        }
        filled += w;
    }
    return filled;
}

int64_t fillRearSurface(Image<Rgba8>* color, Image<float>* depth, Image<uint8_t>* holeMask,
                        Rgba8 clearColor) {
    const int w = color->width(), h = color->height();
    PLX_CHECK(depth->width() == w && depth->height() == h && holeMask->width() == w &&
              holeMask->height() == h);
    int64_t filled = 0;
    for (int y = 0; y < h; ++y) {
        const int n = fillRowRearSurface(color->row(y), depth->row(y), holeMask->row(y), w);
        filled += n > 0 ? n : 0;
    }
    return filled + fillEmptyRows(color, depth, holeMask, clearColor);
}

}  // namespace plx::warp
