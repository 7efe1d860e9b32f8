#pragma once

// The HTML report of a digested log: one file with its charts as inline SVG and its depth
// thumbnails as inline PNG, so it opens offline and travels as a single attachment.

#include <string>

#include "dco/diag/log_digest.hpp"
#include "dco/diag/log_summary.hpp"

namespace dco::diag {

std::string html_report(const LogDigest& digest, const LogSummary& summary);

// RFC 4648 base64 (for data: URIs).
std::string base64(const unsigned char* data, std::size_t size);

// A depth preview as a colour PNG (near warm, far cool, unknown black), `scale` times its size.
// near_mm/far_mm fix the colour scale so thumbnails of one report compare.
std::string preview_png(const ::dco::depth_preview_t& preview, int near_mm, int far_mm, int scale);

}  // namespace dco::diag
