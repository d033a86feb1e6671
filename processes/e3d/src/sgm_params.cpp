#include <limits>
#include <sstream>
#include <stdexcept>

#include "ips/config.hpp"
#include "ips/e3d/sgm.hpp"

namespace ips {
namespace e3d {

void SgmParams::validate() const {
  auto fail = [](const std::string& what) { throw std::invalid_argument("SgmParams: " + what); };
  if (num_disparities < 1 || num_disparities > kMaxDisparities)
    fail("num_disparities must be 1..256, got " + std::to_string(num_disparities));
  if (min_disparity < -4096 || min_disparity > 4096) fail("min_disparity out of range -4096..4096");
  if (p1 < 0 || p1 > 255) fail("p1 must be 0..255, got " + std::to_string(p1));
  if (p2 < p1) fail("p2 must be >= p1 (p1=" + std::to_string(p1) + ", p2=" + std::to_string(p2) + ")");
  int max_cost = 0;
  try {
    max_cost = maxCost(cost);
  } catch (const std::invalid_argument& e) {
    fail(e.what());
  }
  if (p2 + max_cost > 255)
    fail("p2 + " + std::to_string(max_cost) + " must be <= 255 for cost " + cost +
         " (path costs are kept in one byte), got p2=" + std::to_string(p2));
  if (mi_levels < 1 || mi_levels > 8) fail("mi_levels must be 1..8");
  if (mi_coarse_iterations < 1 || mi_coarse_iterations > 8) fail("mi_coarse_iterations must be 1..8");
  if (p2_slope < 0 || p2_slope > 4096) fail("p2_slope must be 0..4096");
  if (paths != 8 && paths != 4) fail("paths must be 4 or 8, got " + std::to_string(paths));
  if (uniqueness < 0 || uniqueness > 99) fail("uniqueness must be 0..99 percent");
  if (lr_max_diff > 256) fail("lr_max_diff must be <= 256 (negative disables the check)");
  if (right_map != "diagonal" && right_map != "match")
    fail("right_map must be diagonal or match, got '" + right_map + "'");
  if (aggregation != "auto" && aggregation != "rows" && aggregation != "lines")
    fail("aggregation must be auto, rows or lines, got '" + aggregation + "'");
}

SgmParams SgmParams::forCost(const std::string& cost) {
  SgmParams p;
  p.cost = cost;
  if (cost == "census") return p;
  maxCost(cost);  // throws for an unknown name
  // Costs 0..63 (grey levels, or quarter bits for mi); chosen like the census ones, by a small grid over (P1, P2,
  // p2_slope) on the six scenes (processes/e3d/README.md).
  if (cost == "ad") {
    p.p1 = 14;
    p.p2 = 160;
    p.p2_slope = 40;
  } else if (cost == "sad") {
    p.p1 = 11;
    p.p2 = 192;
    p.p2_slope = 60;
  } else {  // mi
    p.p1 = 24;
    p.p2 = 120;
    p.p2_slope = 20;
  }
  return p;
}

SgmParams SgmParams::withCost(const std::string& new_cost) const {
  const SgmParams penalties = forCost(new_cost);
  SgmParams p = *this;
  p.cost = penalties.cost;
  p.p1 = penalties.p1;
  p.p2 = penalties.p2;
  p.p2_slope = penalties.p2_slope;
  return p;
}

SgmParams SgmParams::fromConfig(const Config& c) {
  SgmParams p;
  try {
    p = forCost(c.getString("cost", "census"));
  } catch (const std::invalid_argument& e) {
    throw ConfigError(c.path() + ": " + e.what());
  }
  p.num_disparities = c.getInt("num_disparities", p.num_disparities);
  p.min_disparity = c.getInt("min_disparity", p.min_disparity);
  p.p1 = c.getInt("p1", p.p1);
  p.p2 = c.getInt("p2", p.p2);
  p.p2_slope = c.getInt("p2_slope", p.p2_slope);
  p.paths = c.getInt("paths", p.paths);
  p.uniqueness = c.getInt("uniqueness", p.uniqueness);
  p.subpixel = c.getBool("subpixel", p.subpixel);
  p.median = c.getBool("median", p.median);
  p.lr_max_diff = c.getInt("lr_max_diff", p.lr_max_diff);
  p.fill_invalid = c.getBool("fill_invalid", p.fill_invalid);
  p.right_map = c.getString("right_map", p.right_map);
  p.mi_levels = c.getInt("mi_levels", p.mi_levels);
  p.mi_coarse_iterations = c.getInt("mi_coarse_iterations", p.mi_coarse_iterations);
  p.aggregation = c.getString("aggregation", p.aggregation);
  try {
    p.validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(c.path() + ": " + e.what());
  }
  return p;
}

std::string SgmParams::describe() const {
  std::ostringstream s;
  s << cost;
  if (cost == "mi") s << " levels=" << mi_levels << "x" << mi_coarse_iterations;
  s << " D=" << num_disparities << " dmin=" << min_disparity << " P1=" << p1 << " P2=" << p2 << " p2_slope=" << p2_slope
    << " paths=" << paths << " uniq=" << uniqueness << " subpix=" << subpixel << " median=" << median
    << " lr=" << lr_max_diff << " right=" << right_map << " fill=" << fill_invalid << " aggregation=" << aggregation;
  return s.str();
}

cv::Mat disparityToFloat(const cv::Mat& d16) {
  if (d16.type() != CV_16S) throw std::invalid_argument("disparityToFloat: need CV_16S");
  cv::Mat out(d16.size(), CV_32F);
  for (int y = 0; y < d16.rows; ++y)
    for (int x = 0; x < d16.cols; ++x) {
      int16_t v = d16.at<int16_t>(y, x);
      out.at<float>(y, x) =
          v == kInvalidDisparity ? std::numeric_limits<float>::infinity() : static_cast<float>(v) / kSubpixelScale;
    }
  return out;
}

}  // namespace e3d
}  // namespace ips
