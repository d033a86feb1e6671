#include "tool_common.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

#include "ips/config.hpp"

namespace ips {
namespace e3d {

Args::Args(int argc, char** argv, const std::vector<std::string>& flags) {
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a.rfind("--", 0) != 0) throw std::invalid_argument("unexpected argument '" + a + "'");
    a = a.substr(2);
    if (std::find(flags.begin(), flags.end(), a) != flags.end()) {
      values_[a] = "1";
    } else {
      if (i + 1 >= argc) throw std::invalid_argument("option --" + a + " needs a value");
      values_[a] = argv[++i];
    }
  }
}

std::string Args::get(const std::string& key, const std::string& fallback) const {
  auto it = values_.find(key);
  return it == values_.end() ? fallback : it->second;
}

std::string Args::require(const std::string& key) const {
  auto it = values_.find(key);
  if (it == values_.end()) throw std::invalid_argument("missing option --" + key);
  return it->second;
}

int Args::getInt(const std::string& key, int fallback) const {
  if (!has(key)) return fallback;
  try {
    size_t used = 0;
    int v = std::stoi(get(key, ""), &used);
    if (used != get(key, "").size()) throw std::invalid_argument("");
    return v;
  } catch (const std::exception&) {
    throw std::invalid_argument("option --" + key + " needs an integer, got '" + get(key, "") + "'");
  }
}

double Args::getDouble(const std::string& key, double fallback) const {
  if (!has(key)) return fallback;
  try {
    return std::stod(get(key, ""));
  } catch (const std::exception&) {
    throw std::invalid_argument("option --" + key + " needs a number, got '" + get(key, "") + "'");
  }
}

void Args::checkKnown(const std::vector<std::string>& known) const {
  for (const auto& kv : values_)
    if (std::find(known.begin(), known.end(), kv.first) == known.end())
      throw std::invalid_argument("unknown option --" + kv.first);
}

std::vector<std::string> paramKeys() {
  return {"config", "cost",       "num-disparities", "min-disparity", "p1",        "p2",        "p2-slope",
          "paths",  "uniqueness", "lr-max-diff",     "aggregation",   "right-map", "mi-levels", "mi-coarse-iterations"};
}
std::vector<std::string> paramFlags() { return {"no-subpixel", "no-median", "fill"}; }

std::string paramUsage() {
  // The defaults printed are those paramsFromArgs starts from (SgmParams{} and SgmParams::forCost), not a copy.
  const SgmParams d;
  const auto penalties = [](Cost cost) {
    const SgmParams c = SgmParams::forCost(cost);
    return std::string(toString(cost)) + " " + std::to_string(c.p1) + "/" + std::to_string(c.p2) + "/" +
           std::to_string(c.p2_slope);
  };
  const auto yesNo = [](bool on) { return on ? std::string("on") : std::string("off"); };
  std::ostringstream o;
  o << "  SGM options (without --config the built-in defaults shown; --config FILE starts from its section sgm):\n"
    << "    --config FILE           YAML with a section 'sgm' (SgmParams keys), e.g. config/e3d.yaml\n"
    << "    --cost census|ad|sad|mi matching cost (default " << toString(d.cost)
    << "; another cost than the config's takes that cost's penalties)\n"
    << "    --mi-levels N --mi-coarse-iterations N   the Mutual Information hierarchy (default " << d.mi_levels << ", "
    << d.mi_coarse_iterations << ")\n"
    << "    --num-disparities N     1.." << kMaxDisparities << " (default " << d.num_disparities << ")\n"
    << "    --min-disparity N       (default " << d.min_disparity << ")\n"
    << "    --p1 N --p2 N           penalties in cost units (p2 + the cost's maximum, 24 or 63, <= 255)\n"
    << "    --p2-slope N            adaptive P2 = max(P1, P2 - N*|dI|/16), 0 = off\n"
    << "                            (default P1/P2/p2_slope per cost: " << penalties(Cost::census) << ", "
    << penalties(Cost::ad) << ", " << penalties(Cost::sad) << ", " << penalties(Cost::mi) << ")\n"
    << "    --paths 8|4             (default " << d.paths << ")\n"
    << "    --uniqueness PERCENT    0 = off (default " << d.uniqueness << ")\n"
    << "    --lr-max-diff PX        < 0 = no left-right check (default " << d.lr_max_diff << ")\n"
    << "    --no-subpixel --no-median   (default: subpixel " << yesNo(d.subpixel) << ", median " << yesNo(d.median)
    << ")\n"
    << "    --fill                  dense product: invalid pixels take the background of their row neighbours\n"
    << "                            (default " << yesNo(d.fill_invalid) << ": invalid pixels stay invalid)\n"
    << "    --right-map diagonal|match  right map for the check: diagonal search, or a second match right to left\n"
    << "                            (default " << toString(d.right_map) << ")\n"
    << "    --aggregation auto|rows|lines  how the device walks the paths (same results; auto: rows on a CPU device)\n"
    << "                            (default " << toString(d.aggregation) << ")\n";
  return o.str();
}

SgmParams paramsFromArgs(const Args& a) {
  SgmParams p;
  if (a.has("config")) p = SgmParams::fromConfig(Config(a.get("config", "")).section("sgm"));
  if (a.has("cost")) {
    const Cost cost = parseCost(a.get("cost", ""));
    if (cost != p.cost) p = p.withCost(cost);
  }
  p.mi_levels = a.getInt("mi-levels", p.mi_levels);
  p.mi_coarse_iterations = a.getInt("mi-coarse-iterations", p.mi_coarse_iterations);
  p.num_disparities = a.getInt("num-disparities", p.num_disparities);
  p.min_disparity = a.getInt("min-disparity", p.min_disparity);
  p.p1 = a.getInt("p1", p.p1);
  p.p2 = a.getInt("p2", p.p2);
  p.p2_slope = a.getInt("p2-slope", p.p2_slope);
  p.paths = a.getInt("paths", p.paths);
  p.uniqueness = a.getInt("uniqueness", p.uniqueness);
  p.lr_max_diff = a.getInt("lr-max-diff", p.lr_max_diff);
  if (a.has("no-subpixel")) p.subpixel = false;
  if (a.has("no-median")) p.median = false;
  if (a.has("fill")) p.fill_invalid = true;
  p.right_map = parseRightMap(a.get("right-map", toString(p.right_map)));
  p.aggregation = parseAggregation(a.get("aggregation", toString(p.aggregation)));
  p.validate();
  return p;
}

cv::Mat loadGrey(const std::string& path) {
  cv::Mat img = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (img.empty()) throw std::runtime_error("cannot read image '" + path + "'");
  if (img.depth() == CV_16U) img.convertTo(img, CV_8U, 1.0 / 256);
  cv::Mat grey;
  if (img.channels() == 3)
    cv::cvtColor(img, grey, cv::COLOR_BGR2GRAY);
  else if (img.channels() == 4)
    cv::cvtColor(img, grey, cv::COLOR_BGRA2GRAY);
  else
    grey = img;
  return grey;
}

cv::Mat colourDisparity(const cv::Mat& disparity, double max_disparity) {
  cv::Mat scaled(disparity.size(), CV_8U), valid(disparity.size(), CV_8U);
  for (int y = 0; y < disparity.rows; ++y)
    for (int x = 0; x < disparity.cols; ++x) {
      float d = disparity.at<float>(y, x);
      valid.at<uint8_t>(y, x) = std::isfinite(d) ? 255 : 0;
      scaled.at<uint8_t>(y, x) =
          std::isfinite(d) ? cv::saturate_cast<uint8_t>(255.0 * std::max(0.0, double(d)) / max_disparity) : 0;
    }
  cv::Mat colour;
  cv::applyColorMap(scaled, colour, cv::COLORMAP_JET);
  colour.setTo(cv::Scalar(0, 0, 0), valid == 0);
  return colour;
}

}  // namespace e3d
}  // namespace ips
