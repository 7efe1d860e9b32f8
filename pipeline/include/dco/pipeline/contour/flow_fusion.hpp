#pragma once

#include <cstdint>
#include <vector>

#include "dco/core/image.hpp"

// The flow cue of the depth-contour filter (§5.1–5.2). Flow fields are 2-channel (u, v) float
// images in pixels, from the centre frame to one neighbour; all images share one size.
namespace dco::contour {

// Flows shorter than this (pixels) have no usable direction for the projection test.
inline constexpr float kMinFlowForDirection = 1e-2f;

// Eq. 6–8: speed r = |flow| per pixel (written to `speed`), then
// amplitude M(x, y) = max(|r(x+1, y) - r(x, y)|, |r(x, y+1) - r(x, y)|). A difference that would
// reach past the last column or row counts as 0, so the image border is not an edge.
void flow_amplitude(ImageView<const float> flow, ImageView<float> speed,
                    ImageView<float> amplitude);
// Its two steps for rows [y_begin, y_end) of the output: the speed rows, then the amplitude rows
// (each reads the speed of its row and the next).
void flow_speed_rows(ImageView<const float> flow, int y_begin, int y_end, ImageView<float> speed);
void flow_amplitude_rows(ImageView<const float> speed, int y_begin, int y_end,
                         ImageView<float> amplitude);

// Eq. 9–11: with e the unit flow direction at p, p0 = p - distance·e and p1 = p + distance·e
// (bilinear samples, clamped to the image), contrast = flow(p1)·e - flow(p0)·e. It is positive
// where p's motion carries it away from what follows it (p stays visible in the neighbour) and
// negative where p runs into the region ahead (p is covered there). 0 where |flow| is below
// kMinFlowForDirection.
void projection_contrast(ImageView<const float> flow, float distance, ImageView<float> contrast);
// The same for rows [y_begin, y_end) of `contrast`.
void projection_contrast_rows(ImageView<const float> flow, float distance, int y_begin, int y_end,
                              ImageView<float> contrast);

// Eq. 12: per pixel, the amplitude of the field whose contrast is larger (the more reliable of the
// two directions); on a tie, field b.
void fuse_amplitudes(ImageView<const float> amplitude_a, ImageView<const float> contrast_a,
                     ImageView<const float> amplitude_b, ImageView<const float> contrast_b,
                     ImageView<float> fused);
// The same for rows [y_begin, y_end).
void fuse_amplitude_rows(ImageView<const float> amplitude_a, ImageView<const float> contrast_a,
                         ImageView<const float> amplitude_b, ImageView<const float> contrast_b,
                         int y_begin, int y_end, ImageView<float> fused);

// Working memory of invert_flow, sized on first use: a field of the same size reuses it.
struct FlowInversionScratch {
  Image<float> speed;                     // of the source that landed on each pixel
  std::vector<std::int32_t> column, row;  // where the pixels of one row land
  std::vector<float> row_speed;
};

// The field from the neighbour back to the centre, from `forward` (centre -> neighbour): each
// centre pixel p lands on round(p + forward(p)) in the neighbour, which takes -forward(p); where
// several land on one pixel the fastest wins (the nearer surface, under a camera's translation),
// and a run of pixels none lands on (uncovered from behind a moving surface) takes the value at
// its row end that moves less (the farther surface), or 0 on a row with none.
void invert_flow(ImageView<const float> forward, FlowInversionScratch& scratch,
                 ImageView<float> backward);

// The field centre -> far from `near` (centre -> neighbour) and `onward` (neighbour -> far): each
// pixel p goes to p + near(p) in the neighbour and on by `onward` there, sampled bilinearly (the
// border's value past the edge): composed(p) = near(p) + onward(p + near(p)). All 2-channel fields
// of one size; `composed` may not alias either input. Our own loop, since cv::remap allocates on
// every call.
void compose_flow(ImageView<const float> near, ImageView<const float> onward,
                  ImageView<float> composed);

// Divides every value by max(largest value, floor) so the result lies in [0, 1]; returns that
// divisor. A divisor below kLeastFlowDivisor (an image of no motion, with floor 0) leaves the
// values as they are and 0 is returned: the reciprocal of a subnormal is infinite, and 0 times it
// NaN.
inline constexpr float kLeastFlowDivisor = 1e-6f;
float normalise_by_max(ImageView<float> values, float floor);
// Its two steps on rows [y_begin, y_end): the largest value (at least 0), and the division by a
// divisor (> 0) with the result capped at 1.
float largest_value(ImageView<const float> values, int y_begin, int y_end);
void divide_rows(ImageView<float> values, float divisor, int y_begin, int y_end);

}  // namespace dco::contour
