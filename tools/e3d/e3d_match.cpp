// e3d_match: matches one rectified pair on the Vulkan device and writes the left disparity as PFM
// (float pixels, invalid = inf, as Middlebury).
//   e3d_match --left L.png --right R.png --num-disparities N --out disparity.pfm
//             [--out-png colour.png] [--out-right right.pfm] [--device INDEX|NAME] [--check-reference]
//             [SGM options]
#include <iostream>
#include <opencv2/imgcodecs.hpp>

#include "ips/e3d/sgm_options.hpp"
#include "ips/e3d/stereo_matcher.hpp"
#include "ips/eval/disparity.hpp"
#include "ips/image_file.hpp"
#include "ips/pfm.hpp"

using namespace ips::e3d;

int main(int argc, char** argv) {
  try {
    ips::Args args(argc, argv, "matches one rectified pair on the Vulkan device, writes the left disparity as PFM");
    args.required("--left", "L.png", "left image")
        .required("--right", "R.png", "right image")
        .required("--out", "disparity.pfm", "left disparity (float pixels, invalid = inf, as Middlebury)")
        .option("--out-png", "colour.png", "colour-mapped left disparity")
        .option("--out-right", "right.pfm", "right disparity")
        .option("--device", "INDEX|NAME", "Vulkan device (default: env IPS_VK_DEVICE, else the first)")
        .flag("--check-reference", "also run the CPU reference and count differing pixels");
    addSgmOptions(args);
    // Without any argument the usage, as a mistake (exit 2), not the error of the first missing option.
    if (argc == 1) {
      std::cout << args.help();
      return 2;
    }
    if (!args.parse()) return 0;
    const SgmParams params = sgmParamsFromArgs(args);
    const cv::Mat left = ips::loadGrey(args.get("--left")), right = ips::loadGrey(args.get("--right"));
    const std::string out_path = args.get("--out");
    if (left.size() != right.size()) throw std::invalid_argument("left and right images differ in size");

    VulkanContext ctx(args.get("--device"));
    StereoMatcher matcher(ctx, left.size(), params);
    MatchOutput out = matcher.match(left, right, args.has("--out-right"));
    ips::writePfm(out_path, disparityToFloat(out.disparity));
    if (args.has("--out-right")) ips::writePfm(args.get("--out-right"), disparityToFloat(out.right));
    if (args.has("--out-png")) {
      const std::string png = args.get("--out-png");
      // imwrite reports an unwritable path by returning false (or throwing for an unknown extension).
      if (!cv::imwrite(png, ips::eval::colourDisparity(disparityToFloat(out.disparity),
                                                       params.min_disparity + params.num_disparities)))
        throw std::runtime_error("cannot write " + png);
    }
    const int valid = cv::countNonZero(out.disparity != kInvalidDisparity);
    std::cout << left.cols << "x" << left.rows << " " << params.describe() << "\n"
              << "density " << 100.0 * valid / out.disparity.total() << " %, " << out.total_ms << " ms (device "
              << out.device_ms << " ms:";
    for (const auto& s : out.stages) std::cout << " " << s.name << " " << s.ms;
    std::cout << ")\n";
    if (args.getFlag("--check-reference")) {
      SgmResult ref = sgmReference(left, right, params);
      cv::Mat diff = ref.left != out.disparity;
      std::cout << "reference: " << cv::countNonZero(diff) << " pixels differ\n";
      return cv::countNonZero(diff) == 0 ? 0 : 1;
    }
    return 0;
  } catch (const ips::ArgError& e) {
    std::cerr << e.what() << "\n";  // names the program and the option
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "e3d_match: " << e.what() << "\n";
    return 1;
  }
}
