#pragma once
// What the E3D tools share: the SGM options, image loading and the colour map of a disparity.
#include <opencv2/core.hpp>
#include <string>

#include "ips/args.hpp"
#include "ips/e3d/sgm.hpp"

namespace ips {
namespace e3d {

// The SGM options every tool takes: [--config FILE (section sgm)] then --cost --num-disparities --min-disparity
// --p1 --p2 --p2-slope --paths --uniqueness --lr-max-diff --no-subpixel --no-median --fill --right-map
// --aggregation --mi-levels --mi-coarse-iterations override it. Their --help texts state the defaults
// sgmParamsFromArgs really starts from (SgmParams{} and SgmParams::forCost); none has an Args default, so that
// has() tells whether it was given.
void addSgmOptions(ips::Args& args);
SgmParams sgmParamsFromArgs(const ips::Args& args);

// Reads an image and converts it to 8-bit grey (COLOR_BGR2GRAY); throws naming the file.
cv::Mat loadGrey(const std::string& path);

// Colour-maps a CV_32F disparity (inf = invalid, drawn black) over [0, max_disparity].
cv::Mat colourDisparity(const cv::Mat& disparity, double max_disparity);

}  // namespace e3d
}  // namespace ips
