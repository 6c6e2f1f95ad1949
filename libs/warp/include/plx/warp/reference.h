#pragma once
// Reference views and reference sets (Mark, Bishop, McMillan, "The Remote Rendering System":
// "this rendering computer renders four sides of a cube"). Each view is an ordinary render; its
// depth target already holds 1/w, the generalised disparity the warp needs, so no extra pass.

#include <vector>

#include <plx/warp/warp.h>

namespace plx::warp {

// Checks a pose: finite, forward and up of non-zero length and not parallel. The message names
// the problem ("pose: eye is not finite").
Status checkPose(const Pose& pose);

// Checks reference set options (layout, face size, field of view, aspect, near and far planes).
Status checkReferenceSetOptions(const ReferenceSetOptions& options);

// The cameras of a reference set: cube4 looks forward, right, back, left (90-degree square
// faces, up = the pose's up made orthogonal to forward); cube6 adds up and down; wide is one
// camera along forward. Errors: as checkPose and checkReferenceSetOptions.
Result<std::vector<Camera>> referenceCameras(const Pose& pose, const ReferenceSetOptions& options);

// The pose of a scene viewpoint: its eye, the unit direction to its target, its up.
Pose poseAt(const scene::Viewpoint& viewpoint);

// Fills view->rowMinDisparity and rowMaxDisparity from view->disparity (without NaN; a -0 counts
// as below +0).
void computeRowDisparityRange(ReferenceView* view);

}  // namespace plx::warp
