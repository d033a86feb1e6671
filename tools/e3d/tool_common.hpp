#pragma once
// Command-line handling shared by the E3D tools.
#include <map>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "ips/e3d/sgm.hpp"

namespace ips {
namespace e3d {

// "--key value" pairs and "--flag" switches. Unknown keys are an error (listed by the caller's usage text).
class Args {
 public:
  Args(int argc, char** argv, const std::vector<std::string>& flags);
  bool has(const std::string& key) const { return values_.count(key) > 0; }
  std::string get(const std::string& key, const std::string& fallback) const;
  std::string require(const std::string& key) const;
  int getInt(const std::string& key, int fallback) const;
  double getDouble(const std::string& key, double fallback) const;
  // Throws std::invalid_argument naming the first key not in `known`.
  void checkKnown(const std::vector<std::string>& known) const;

 private:
  std::map<std::string, std::string> values_;
};

// The SGM options every tool takes: [--config FILE (section sgm)] then --num-disparities --min-disparity --p1
// --p2 --p2-slope --paths --uniqueness --lr-max-diff --no-subpixel --no-median override it.
SgmParams paramsFromArgs(const Args& args);
std::vector<std::string> paramKeys();
std::vector<std::string> paramFlags();
// Usage text of the SGM options, with the defaults paramsFromArgs really starts from (SgmParams{}).
std::string paramUsage();

// Reads an image and converts it to 8-bit grey (COLOR_BGR2GRAY); throws naming the file.
cv::Mat loadGrey(const std::string& path);

// Colour-maps a CV_32F disparity (inf = invalid, drawn black) over [0, max_disparity].
cv::Mat colourDisparity(const cv::Mat& disparity, double max_disparity);

}  // namespace e3d
}  // namespace ips
