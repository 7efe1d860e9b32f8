#pragma once

#include <cstdint>

#include "dco/core/image.hpp"

// The ground truth with Gaussian noise added, scored as a prediction: what a matcher whose only
// error is that noise would score. The occlusion metrics put virtual planes among the scene's
// own disparities, so pixels near a plane change side under errors far below bad-2's 2 px; this
// shows how much of a score such errors alone account for, scene by scene.
namespace dco::tools {

// `gt` with an independent N(0, sigma_px²) sample (OpenCV's RNG seeded with `seed`: the same
// seed gives the same map) added to every usable disparity; unknown pixels stay unknown. A
// noisy value at or below 0 becomes the smallest positive float, so every GT pixel keeps a
// prediction. Throws dco::Error for a negative or non-finite sigma_px.
Image<float> noisy_ground_truth(ImageView<const float> gt, double sigma_px, std::uint64_t seed);

}  // namespace dco::tools
