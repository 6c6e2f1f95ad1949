#pragma once
// The two rendering passes of Bimber et al. section 2 on the software rasterizer.
//
// Pass 1 renders the scene for the tracked viewer into an image whose frustum is the image
// plane's. Pass 2 draws the warp mesh, vertices at their display positions, texture-mapped with
// that image into the display framebuffer. Pass 2 places the mesh on a plane parallel to the
// image plane of a perspective camera sized to the framebuffer, which projects affinely, so the
// texture mapping is exactly the linear interpolation the error metric assumes.

#include <memory>
#include <vector>

#include <plx/display/quadtree.h>
#include <plx/raster/raster.h>

namespace plx::display {

// Scales and moves a scene (in metres or any unit) so that its bounding box's sphere is the
// display's content sphere (millimetres), its viewpoints with it. Precondition: the scene is
// finalized.
scene::Scene fitSceneToContent(const scene::Scene& scene, const Display& display);

// All vertex positions of a scene, for the container.
std::vector<DVec3> scenePointsMm(const scene::Scene& scene);

// Pass 1: the scene seen from the image plane's eye, sizePx x sizePx. Precondition: sizePx in
// [1, 16384].
Status renderViewerImage(raster::Renderer& renderer, const scene::Scene& sceneMm,
                         const ImagePlane& plane, int sizePx, Image<Rgba8>* image,
                         double* milliseconds);

// Pass 2 frame after frame: keeps one multithreaded Renderer, the warp scene (texture, mesh
// buffers) and the framebuffers between frames, so a warm frame allocates nothing.
//
// The pass-1 image becomes the texture's base level only, with no mip chain: a predistortion warp
// is close to 1:1 (one pass-1 texel per display pixel within a factor of about two on the
// displays shipped), so the minification a mip chain would filter is mild, while building the
// chain costs a full pass over the image every frame. The renderer clamps its level choice to
// the levels present, so it samples the base level bilinearly everywhere.
class PredistortRenderer {
public:
    // threads: renderer threads (0 = all hardware threads).
    static Result<std::unique_ptr<PredistortRenderer>> create(int threads);
    ~PredistortRenderer();

    // Renders the mesh textured with viewerImage into the display framebuffer and returns it
    // (valid until the next call). Precondition: the mesh's vertices are finite. Copies
    // viewerImage into viewerImage() first (timed with the frame).
    Result<const Image<Rgba8>*> render(const Display& display, const WarpMesh& mesh,
                                       const Image<Rgba8>& viewerImage,
                                       double* milliseconds = nullptr);

    // The same with the pass-1 image already in viewerImage(): no copy.
    Result<const Image<Rgba8>*> render(const Display& display, const WarpMesh& mesh,
                                       double* milliseconds = nullptr);

    // The pass-1 image the warp samples, kept between frames. Render pass 1 straight into it
    // (renderViewerImage(..., &viewerImage(), ...)) and a frame copies nothing; an empty image
    // gives a black frame.
    Image<Rgba8>& viewerImage();

    raster::Renderer& renderer();

    // true (the default): draw the warp mesh colour-only (no depth test, depth and ID targets
    // untouched) and clear only the tiles drawn into, whenever its triangles all keep their
    // orientation (the mesh does not fold over, so none overlap: the same image as the
    // depth-tested render, which a folded mesh still gets). false: depth-tested, whole clear
    // every frame, as before.
    void setColorOnly(bool enabled);

private:
    struct Impl;
    explicit PredistortRenderer(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> mImpl;
};

// Draws the mesh's triangle edges over a copy of `background` (or black), in display pixels.
Image<Rgba8> drawMeshOverlay(const Display& display, const WarpMesh& mesh,
                             const Image<Rgba8>* background);

}  // namespace plx::display
