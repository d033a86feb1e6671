// e3d_eval: accuracy of E3D (and, with --opencv, of OpenCV StereoSGBM MODE_HH and MODE_SGBM_3WAY with fixed
// settings; with --peer-cmd, of an external matcher) on
// the scenes of ../shared/data/stereo. Per scene: bad 0.5/1/2/4 px in the non-occluded region and in all
// evaluated pixels (pixels without a disparity count as bad), mean absolute error of the valid disparities
// (all region), density (all and nonocc); writes colour-mapped disparity PNGs.
//   e3d_eval [--data DIR] [--scenes a,b,..] [--out-dir DIR] [--opencv] [--device D | --reference] [SGM options]
//   e3d_eval --radiometric [--costs census,ad,sad,mi] [...]: the right image changed before matching (gain 0.7,
//       offset +30, gamma 1.5, vignetting 40 % at the corners); bad 2.0 (nonocc) of each cost and change, each cost
//       with its own penalties (SgmParams::forCost) and the other options as given.
// The search range is the scene's num_disparities unless --num-disparities is given.
#include <dirent.h>

#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <map>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "ips/data_dir.hpp"
#include "ips/e3d/matching_cost.hpp"
#include "ips/e3d/sgm_options.hpp"
#include "ips/e3d/stereo_matcher.hpp"
#include "ips/eval/disparity.hpp"
#include "ips/image_file.hpp"
#include "ips/pfm.hpp"

using namespace ips::e3d;

namespace {

struct Scene {
  std::string name, dir;
  cv::Mat left, right;
  cv::Mat gt;      // CV_32F, NaN = unknown
  cv::Mat nonocc;  // CV_8U, 255 = evaluated
  cv::Mat all;     // CV_8U, 255 = evaluated
  int num_disparities = 0;
};

Scene loadScene(const std::string& dir) {
  cv::FileStorage fs(dir + "/scene.yaml", cv::FileStorage::READ);
  if (!fs.isOpened()) throw std::runtime_error("cannot read " + dir + "/scene.yaml");
  Scene s;
  s.dir = dir;
  s.name = (std::string)fs["name"];
  s.left = ips::loadGrey(dir + "/" + (std::string)fs["left"]);
  s.right = ips::loadGrey(dir + "/" + (std::string)fs["right"]);
  s.num_disparities = (int)fs["num_disparities"];
  const std::string format = (std::string)fs["gt_format"];
  const double scale = (double)fs["gt_scale"];
  const std::string invalid = (std::string)fs["gt_invalid"];
  const std::string gt_path = dir + "/" + (std::string)fs["gt"];
  cv::Mat raw;
  if (format == "pfm") {
    raw = ips::readPfm(gt_path);
  } else {
    cv::imread(gt_path, cv::IMREAD_UNCHANGED).convertTo(raw, CV_32F);
    if (raw.empty()) throw std::runtime_error("cannot read " + gt_path);
  }
  s.gt = cv::Mat(raw.size(), CV_32F);
  for (int y = 0; y < raw.rows; ++y)
    for (int x = 0; x < raw.cols; ++x) {
      const float v = raw.at<float>(y, x);
      const bool unknown = invalid == "inf" ? !std::isfinite(v) : v == std::stof(invalid);
      s.gt.at<float>(y, x) = unknown ? NAN : static_cast<float>(v / scale);
    }
  const int border = fs["border"].empty() ? 0 : (int)fs["border"];
  cv::Mat known = s.gt == s.gt;  // not NaN
  cv::Mat inner(known.size(), CV_8U, cv::Scalar(0));
  inner(cv::Rect(border, border, known.cols - 2 * border, known.rows - 2 * border)).setTo(255);
  known &= inner;
  auto mask = [&](const char* key) {
    if (fs[key].empty()) return cv::Mat();
    cv::Mat m = cv::imread(dir + "/" + (std::string)fs[key], cv::IMREAD_GRAYSCALE);
    if (m.empty()) throw std::runtime_error("cannot read mask " + (std::string)fs[key]);
    return m;
  };
  cv::Mat nonocc = mask("mask_nonocc"), all = mask("mask_all");
  s.nonocc = nonocc.empty() ? known.clone() : ((nonocc == 255) & known);
  if (!all.empty())
    s.all = (all == 255) & known;
  else if (!nonocc.empty())
    s.all = (nonocc > 0) & known;  // Middlebury 2014: 255 nonocc, 128 occluded
  else
    s.all = known.clone();
  return s;
}

struct Scores {
  double bad_nonocc[4] = {0, 0, 0, 0}, bad_all[4] = {0, 0, 0, 0};
  double mean_error = 0, density = 0;
  double density_nonocc = 0;  // share of the nonocc pixels with a disparity (occluded pixels are rightly invalid)
  double bad2_valid = 0;      // bad 2.0 % among the valid nonocc pixels: whether added pixels are right ones
};

const double kThresholds[4] = {0.5, 1.0, 2.0, 4.0};

Scores score(const Scene& s, const cv::Mat& disp /* CV_32F, inf = invalid */) {
  const std::vector<double> thresholds(std::begin(kThresholds), std::end(kThresholds));
  const ips::eval::DisparityErrors all = ips::eval::disparityErrors(disp, s.gt, thresholds, s.all);
  const ips::eval::DisparityErrors non = ips::eval::disparityErrors(disp, s.gt, thresholds, s.all & s.nonocc);
  Scores r;
  for (int t = 0; t < 4; ++t) {
    r.bad_all[t] = all.badPct(t);
    r.bad_nonocc[t] = non.badPct(t);
  }
  r.mean_error = all.meanAbsError();
  r.density = all.densityPct();
  r.density_nonocc = non.densityPct();
  r.bad2_valid = non.badValidPct(2);
  return r;
}

// OpenCV StereoSGBM (MODE_HH or MODE_SGBM_3WAY) with the settings of a census-like SGM, no speckle filter; CV_16S
// x16 as E3D's maps, its invalid pixels (negative) set to kInvalidDisparity so that the same fill applies.
cv::Mat openCvSgbm(const Scene& s, int num_disparities, int mode) {
  auto sgbm = cv::StereoSGBM::create(0, num_disparities, 5, 8 * 25, 32 * 25, 1, 0, 10, 0, 0, mode);
  cv::Mat d16;
  sgbm->compute(s.left, s.right, d16);
  d16.setTo(kInvalidDisparity, d16 < 0);
  return d16;
}

// A peer matcher run as an external program: PEER_CMD LEFT.png RIGHT.png NUM_DISPARITIES OUT.pfm (PFM float,
// inf or negative = invalid). Its map is rounded to 1/16 px into CV_16S (E3D's form), so the same fill applies.
cv::Mat peerMatch(const std::string& cmd, const std::string& scene_dir, int num_disparities,
                  const std::string& out_pfm) {
  const std::string line = cmd + " '" + scene_dir + "/left.png' '" + scene_dir + "/right.png' " +
                           std::to_string(num_disparities) + " '" + out_pfm + "'";
  if (std::system(line.c_str()) != 0) throw std::runtime_error("peer command failed: " + line);
  const cv::Mat d = cv::imread(out_pfm, cv::IMREAD_UNCHANGED);
  if (d.empty() || d.type() != CV_32FC1) throw std::runtime_error("peer output '" + out_pfm + "' is not a PFM map");
  cv::Mat d16(d.size(), CV_16S);
  for (int y = 0; y < d.rows; ++y)
    for (int x = 0; x < d.cols; ++x) {
      const float v = d.at<float>(y, x);
      d16.at<int16_t>(y, x) =
          (std::isfinite(v) && v >= 0) ? static_cast<int16_t>(std::lround(v * kSubpixelScale)) : kInvalidDisparity;
    }
  return d16;
}

void printRow(const std::string& scene, const std::string& method, const Scores& r) {
  std::cout << std::left << std::setw(18) << scene << std::setw(10) << method << std::right << std::fixed
            << std::setprecision(2);
  for (int t = 0; t < 4; ++t) std::cout << std::setw(7) << r.bad_nonocc[t];
  for (int t = 0; t < 4; ++t) std::cout << std::setw(7) << r.bad_all[t];
  std::cout << std::setw(7) << r.mean_error << std::setw(8) << r.density << std::setw(8) << r.density_nonocc
            << std::setw(8) << r.bad2_valid << "\n";
}

// The right image as another camera or exposure would see it: the radiometric changes of --radiometric.
const char* const kChanges[] = {"none", "gain", "offset", "gamma", "vignetting"};

cv::Mat changeRadiometry(const cv::Mat& image, const std::string& change) {
  cv::Mat out(image.size(), CV_8UC1);
  const double cx = (image.cols - 1) / 2.0, cy = (image.rows - 1) / 2.0, r2max = cx * cx + cy * cy;
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x) {
      const double v = image.at<uint8_t>(y, x);
      double w = v;
      if (change == "gain") w = 0.7 * v;
      if (change == "offset") w = v + 30;
      if (change == "gamma") w = 255.0 * std::pow(v / 255.0, 1.5);
      if (change == "vignetting") w = v * (1.0 - 0.4 * ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / r2max);
      out.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(w);
    }
  return out;
}

// --radiometric: bad 2.0 (nonocc) of each cost under each change of the right image.
int radiometricTable(const std::vector<std::string>& names, const std::string& data, const SgmParams& base,
                     const ips::Args& args, VulkanContext& ctx) {
  std::vector<std::string> costs = {"census", "ad", "sad", "mi"};
  if (args.has("--costs")) {
    costs.clear();
    std::stringstream ss(args.get("--costs"));
    for (std::string c; std::getline(ss, c, ',');) costs.push_back(c);
  }
  for (const auto& cost : costs) parseCost(cost);  // a bad name fails before any matching
  std::cout << "bad 2.0 % (nonocc, invalid counted as bad) with the right image changed\n"
            << std::left << std::setw(18) << "scene" << std::setw(8) << "cost" << std::right;
  for (const char* c : kChanges) std::cout << std::setw(11) << c;
  std::cout << "\n";
  std::map<std::string, std::vector<double>> sums;
  for (const auto& name : names) {
    Scene s = loadScene(data + "/" + name);
    for (const auto& cost : costs) {
      SgmParams p = base.withCost(parseCost(cost));
      if (!args.has("--num-disparities")) p.num_disparities = s.num_disparities;
      StereoMatcher matcher(ctx, s.left.size(), p);
      std::cout << std::left << std::setw(18) << name << std::setw(8) << cost << std::right << std::fixed
                << std::setprecision(2);
      auto& sum = sums[cost];
      sum.resize(std::size(kChanges), 0.0);
      for (size_t c = 0; c < std::size(kChanges); ++c) {
        const cv::Mat right = changeRadiometry(s.right, kChanges[c]);
        const Scores e = score(s, disparityToFloat(matcher.match(s.left, right).disparity));
        std::cout << std::setw(11) << e.bad_nonocc[2];
        sum[c] += e.bad_nonocc[2];
      }
      std::cout << "\n";
    }
  }
  for (const auto& cost : costs) {
    std::cout << std::left << std::setw(18) << "average" << std::setw(8) << cost << std::right;
    for (double v : sums[cost]) std::cout << std::setw(11) << v / names.size();
    std::cout << "\n";
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    ips::Args args(argc, argv,
                   "accuracy of E3D (and of OpenCV StereoSGBM, or an external matcher) on the stereo scenes;\n"
                   "every method unfilled and with the same background fill (+f). The search range is the scene's\n"
                   "num_disparities unless --num-disparities is given.");
    args.option("--data", "DIR", "folder of the scenes", ips::dataPath("stereo"))
        .option("--scenes", "a,b,..", "these scenes only (default: every folder in --data)")
        .option("--out-dir", "DIR", "write colour-mapped disparity PNGs here")
        .flag("--opencv", "also OpenCV StereoSGBM MODE_HH and MODE_SGBM_3WAY with fixed settings")
        .option("--device", "D", "Vulkan device (default: env IPS_VK_DEVICE, else the first)")
        .flag("--reference",
              "E3D by its plain C++ reference (sgmReference, slow) instead of the device; the narrowed\n"
              "search (--search narrowed) runs only there so far, and prints the share of the volume searched")
        .option("--peer-cmd", "CMD",
                "also an external matcher, run as CMD LEFT.png RIGHT.png NUM_DISPARITIES OUT.pfm\n"
                "(PFM, inf = invalid)")
        .option("--peer-name", "NAME", "its name in the table", "peer")
        .option("--peer-tmp", "FILE.pfm", "its output file", "/tmp/e3d_eval_peer.pfm")
        .flag("--radiometric",
              "instead: bad 2.0 (nonocc) of each cost with the right image changed (gain, offset, gamma,\n"
              "vignetting), each cost with its own penalties and the other options as given")
        .option("--costs", "census,ad,sad,mi", "the costs of --radiometric (default: all)");
    addSgmOptions(args);
    if (!args.parse()) return 0;
    const std::string data = args.get("--data");
    std::vector<std::string> names;
    if (args.has("--scenes")) {
      std::stringstream ss(args.get("--scenes"));
      for (std::string n; std::getline(ss, n, ',');) names.push_back(n);
    } else {
      DIR* d = opendir(data.c_str());
      if (!d) throw std::runtime_error("cannot open " + data);
      while (dirent* e = readdir(d))
        if (e->d_name[0] != '.') names.push_back(e->d_name);
      closedir(d);
      std::sort(names.begin(), names.end());
    }
    const std::string out_dir = args.get("--out-dir");
    const SgmParams base = sgmParamsFromArgs(args);
    VulkanContext ctx(args.get("--device"));
    if (args.getFlag("--radiometric")) return radiometricTable(names, data, base, args, ctx);
    std::cout << "E3D: " << base.describe() << " (num_disparities per scene unless given)\n";
    std::cout
        << std::left << std::setw(18) << "scene" << std::setw(10) << "method" << std::right
        << "  nonocc: b0.5   b1.0   b2.0   b4.0 | all: b0.5   b1.0   b2.0   b4.0   mean  density  dens_n  b2.0v\n";
    // Every method's raw map is scored unfilled and with the same fill (fillInvalid, the CPU reference of E3D's
    // fill), so that no method gains from a post-processing the others lack.
    struct Sums {
      double bad2_nonocc = 0, bad2_all = 0, density = 0, density_nonocc = 0, bad2_valid = 0;
    };
    std::map<std::string, Sums> sums;
    double searched[2] = {0, 0};  // narrowed search: the share of the volume searched, without and with the coarse
    std::vector<std::string> order;
    int count = 0;
    for (const auto& name : names) {
      Scene s = loadScene(data + "/" + name);
      SgmParams p = base;
      if (!args.has("--num-disparities")) p.num_disparities = s.num_disparities;
      const bool fill_requested = p.fill_invalid;
      p.fill_invalid = false;
      std::vector<std::pair<std::string, cv::Mat>> raw;
      if (args.getFlag("--reference")) {
        raw.emplace_back("e3d", sgmReference(s.left, s.right, p).left);
        if (p.search == Search::narrowed) {
          const cv::Mat coarse = sgmReference(halfSize(s.left), halfSize(s.right), coarseLevelParams(p)).left;
          const DisparityBands bands = narrowedBands(coarse, s.left.size(), p);
          size_t wide = 0, full = 0;
          for (size_t i = 0; i < bands.lo.size(); ++i) {
            wide += bands.width(i) > p.band_width;
            full += bands.width(i) == p.num_disparities;
          }
          const double n = static_cast<double>(bands.lo.size());
          const double share = bands.searchedShare();
          // The coarse level: a quarter of the pixels over about half the range.
          const double coarse_share = 0.25 * coarseLevelParams(p).num_disparities / p.num_disparities;
          searched[0] += share;
          searched[1] += share + coarse_share;
          std::cout << std::left << std::setw(18) << name << "bands: searched " << std::fixed << std::setprecision(1)
                    << 100.0 * share << " % of the volume (+ coarse " << 100.0 * coarse_share << " %), wider than "
                    << p.band_width << ": " << 100.0 * wide / n << " % of the pixels, full range: " << 100.0 * full / n
                    << " %\n";
        }
      } else {
        StereoMatcher matcher(ctx, s.left.size(), p);
        raw.emplace_back("e3d", matcher.match(s.left, s.right).disparity);
      }
      if (args.getFlag("--opencv")) {
        raw.emplace_back("cv_hh", openCvSgbm(s, p.num_disparities, cv::StereoSGBM::MODE_HH));
        raw.emplace_back("cv_3way", openCvSgbm(s, p.num_disparities, cv::StereoSGBM::MODE_SGBM_3WAY));
      }
      if (args.has("--peer-cmd"))
        raw.emplace_back(args.get("--peer-name"), peerMatch(args.get("--peer-cmd"), data + "/" + name,
                                                            p.num_disparities, args.get("--peer-tmp")));
      for (const auto& [method, d16] : raw)
        for (const bool filled : {false, true}) {
          // Without --opencv or a peer the E3D row follows the configuration's fill alone, as before.
          if (!args.getFlag("--opencv") && !args.has("--peer-cmd") && filled != fill_requested) continue;
          cv::Mat map = d16.clone();
          if (filled) fillInvalid(map);
          const std::string label = method + (filled ? "+f" : "");
          const cv::Mat disp = disparityToFloat(map);
          const Scores e = score(s, disp);
          printRow(name, label, e);
          if (!sums.count(label)) order.push_back(label);
          Sums& sum = sums[label];
          sum.bad2_nonocc += e.bad_nonocc[2];
          sum.bad2_all += e.bad_all[2];
          sum.density += e.density;
          sum.density_nonocc += e.density_nonocc;
          sum.bad2_valid += e.bad2_valid;
          if (!out_dir.empty())
            cv::imwrite(out_dir + "/" + name + "_" + label + ".png",
                        ips::eval::colourDisparity(disp, s.num_disparities));
        }
      ++count;
    }
    // nonocc: the pixels each scene's evaluation mask marks as evaluated; all: occluded pixels too. Invalid
    // pixels count as bad in both. "+f": with the background fill.
    std::cout << "mean over " << count
              << " scenes: method  bad2.0 nonocc  bad2.0 all  density  density nonocc  bad2.0 of valid nonocc\n";
    for (const auto& label : order) {
      const Sums& sum = sums[label];
      std::cout << "average " << std::left << std::setw(10) << label << std::right << std::setw(8)
                << sum.bad2_nonocc / count << std::setw(12) << sum.bad2_all / count << std::setw(9)
                << sum.density / count << std::setw(9) << sum.density_nonocc / count << std::setw(9)
                << sum.bad2_valid / count << "\n";
    }
    if (searched[1] > 0)
      std::cout << "narrowed search: mean share of the full volume searched " << 100.0 * searched[0] / count
                << " %, with the coarse level " << 100.0 * searched[1] / count << " %\n";
    return 0;
  } catch (const ips::ArgError& e) {
    std::cerr << e.what() << "\n";  // names the program and the option
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "e3d_eval: " << e.what() << "\n";
    return 1;
  }
}
