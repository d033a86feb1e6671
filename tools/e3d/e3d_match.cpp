// e3d_match: matches one rectified pair on the Vulkan device and writes the left disparity as PFM
// (float pixels, invalid = inf, as Middlebury).
//   e3d_match --left L.png --right R.png --num-disparities N --out disparity.pfm
//             [--out-png colour.png] [--out-right right.pfm] [--device INDEX|NAME] [--check-reference]
//             [SGM options]
#include <iostream>
#include <opencv2/imgcodecs.hpp>

#include "ips/e3d/stereo_matcher.hpp"
#include "ips/pfm.hpp"
#include "tool_common.hpp"

using namespace ips::e3d;

int main(int argc, char** argv) {
  try {
    std::vector<std::string> flags = paramFlags();
    flags.push_back("help");
    flags.push_back("check-reference");
    Args args(argc, argv, flags);
    if (args.has("help") || argc == 1) {
      std::cout << "usage: e3d_match --left L.png --right R.png --num-disparities N --out disparity.pfm\n"
                   "  [--out-png colour.png] [--out-right right.pfm] [--device INDEX|NAME (or env IPS_VK_DEVICE)]\n"
                   "  [--check-reference  also run the CPU reference and count differing pixels]\n"
                << paramUsage();
      return argc == 1 ? 2 : 0;
    }
    std::vector<std::string> known = paramKeys();
    for (const char* k : {"left", "right", "out", "out-png", "out-right", "device"}) known.push_back(k);
    for (const auto& f : flags) known.push_back(f);
    args.checkKnown(known);
    const SgmParams params = paramsFromArgs(args);
    const cv::Mat left = loadGrey(args.require("left")), right = loadGrey(args.require("right"));
    const std::string out_path = args.require("out");
    if (left.size() != right.size()) throw std::invalid_argument("left and right images differ in size");

    VulkanContext ctx(args.get("device", ""));
    StereoMatcher matcher(ctx, left.size(), params);
    MatchOutput out = matcher.match(left, right, args.has("out-right"));
    ips::writePfm(out_path, disparityToFloat(out.disparity));
    if (args.has("out-right")) ips::writePfm(args.get("out-right", ""), disparityToFloat(out.right));
    if (args.has("out-png")) {
      const std::string png = args.get("out-png", "");
      // imwrite reports an unwritable path by returning false (or throwing for an unknown extension).
      if (!cv::imwrite(png,
                       colourDisparity(disparityToFloat(out.disparity), params.min_disparity + params.num_disparities)))
        throw std::runtime_error("cannot write " + png);
    }
    const int valid = cv::countNonZero(out.disparity != kInvalidDisparity);
    std::cout << left.cols << "x" << left.rows << " " << params.describe() << "\n"
              << "density " << 100.0 * valid / out.disparity.total() << " %, " << out.total_ms << " ms (device "
              << out.device_ms << " ms:";
    for (const auto& s : out.stages) std::cout << " " << s.name << " " << s.ms;
    std::cout << ")\n";
    if (args.has("check-reference")) {
      SgmResult ref = sgmReference(left, right, params);
      cv::Mat diff = ref.left != out.disparity;
      std::cout << "reference: " << cv::countNonZero(diff) << " pixels differ\n";
      return cv::countNonZero(diff) == 0 ? 0 : 1;
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "e3d_match: " << e.what() << "\n";
    return 1;
  }
}
