#pragma once
// The SGM options of the E3D command-line tools (e3d_match, e3d_eval, e3d_bench), declared once on ips::Args.
#include "ips/args.hpp"
#include "ips/e3d/sgm.hpp"

namespace ips {
namespace e3d {

// [--config FILE (section sgm)] then --cost --num-disparities --min-disparity --p1 --p2 --p2-slope --paths
// --uniqueness --lr-max-diff --no-subpixel --no-median --fill --right-map --aggregation --mi-levels
// --mi-coarse-iterations override it. Their --help texts state the defaults sgmParamsFromArgs really starts from
// (SgmParams{} and SgmParams::forCost); none has an Args default, so that has() tells whether it was given.
void addSgmOptions(ips::Args& args);
SgmParams sgmParamsFromArgs(const ips::Args& args);

}  // namespace e3d
}  // namespace ips
