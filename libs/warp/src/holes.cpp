// The rear-surface hole fill (holes.h; Mark, Bishop, McMillan, "Improving Quality of Final
// Images").

#include <plx/warp/holes.h>

namespace plx::warp {

int64_t fillRearSurface(Image<Rgba8>* color, Image<float>* depth, Image<uint8_t>* holeMask,
                        Rgba8 clearColor, const int* rowHoles) {
    const int w = color->width(), h = color->height();
    PLX_CHECK(depth->width() == w && depth->height() == h && holeMask->width() == w &&
              holeMask->height() == h);
    int64_t filled = 0;
    std::vector<int> emptyRows;
    for (int y = 0; y < h; ++y) {
        if (rowHoles && rowHoles[y] == 0) continue;
        Rgba8* c = color->row(y);
        float* d = depth->row(y);
        uint8_t* m = holeMask->row(y);
        int x = 0;
        bool anyCovered = false;
        while (x < w) {
            if (m[x] != 1) {
                anyCovered = true;
                ++x;
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
        if (!anyCovered) emptyRows.push_back(y);
    }
    // Rows nothing reached: copy the nearest row that has pixels (already filled), else clear.
    for (int y : emptyRows) {
        int src = -1;
        for (int dy = 1; dy < h && src < 0; ++dy) {
            if (y - dy >= 0 && holeMask->at(0, y - dy) != 1) src = y - dy;
            else if (y + dy < h && holeMask->at(0, y + dy) != 1) src = y + dy;
        }
        Rgba8* c = color->row(y);
        float* d = depth->row(y);
        uint8_t* m = holeMask->row(y);
        for (int x = 0; x < w; ++x) {
            c[x] = src >= 0 ? color->at(x, src) : clearColor;
            d[x] = src >= 0 ? depth->at(x, src) : 0.0f;
            m[x] = 2;
        }
        filled += w;
    }
    return filled;
}

}  // namespace plx::warp
