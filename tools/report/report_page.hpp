// The report page: one self-contained HTML file (report_page.html filled with the run's data and the JavaScript
// libraries it draws with, inlined so that it opens from file:// on a machine without network), and the pictures
// it shows, colour-mapped here so that the page only places them.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "ips/calibration.hpp"
#include "ips/eval/run_report.hpp"

namespace ips::report {

// The samples the page draws of a series over time (a filter's errors, the tracker's matches, a process's latency):
// enough for a line that looks continuous at a screen's width, few enough that the page stays a few megabytes.
constexpr size_t kMaxPageErrorSamples = 2000;

// A JSON array of numbers with `digits` significant digits (non-finite values as null).
std::string jsonArray(const std::vector<double>& values, int digits = 6);
// A JSON string literal.
std::string jsonString(const std::string& value);

// The image as a PNG data URI (data:image/png;base64,...).
std::string pngDataUri(const cv::Mat& image);

// values (CV_32F) mapped linearly from [vmin, vmax] through the OpenCV colour map (clamped at both ends); the
// pixels where `marked` is non-zero get `marked_bgr` instead.
cv::Mat colourMapped(const cv::Mat& values, double vmin, double vmax, int colormap, const cv::Mat& marked,
                     const cv::Scalar& marked_bgr);
// The colour map's 256 colours as a 256x1 image, low values left: the colour bar beside a colour-mapped image
// is drawn from the same table as the image.
std::string colourBarDataUri(int colormap);
// "#rrggbb" of a BGR colour, for the page's legend swatches.
std::string cssColour(const cv::Scalar& bgr);

// The page's disparity pictures: maps on OpenCV's TURBO colour map, the error on INFERNO, and the colours of the
// pixels they cannot show.
struct DisparityColours {
  cv::Scalar invalid{255, 255, 255};        // no disparity (estimate or ground truth)
  cv::Scalar not_evaluated{160, 160, 160};  // error map: no ground truth
  cv::Scalar no_estimate{255, 255, 0};      // error map: a ground truth but no estimate
};
// The colour tables and pixel colours above as the page's "colour_maps" JSON object.
std::string colourMapsJson(const DisparityColours& colours = {});

// One disparity example as the page's JSON object: the rectified left image (8-bit, the map's size), the
// estimate and, if not empty, the ground truth at the map's scale (CV_32F [px], negative where there is none)
// colour-mapped over [dmin, dmax], and the error |estimate - truth| over [0, error_max]. `fields` (JSON members,
// each with a leading ", ") are added as they are.
std::string disparityExampleJson(const cv::Mat& left, const cv::Mat& estimate, const cv::Mat& truth, double dmin,
                                 double dmax, double error_max, const std::string& fields,
                                 const DisparityColours& colours = {});

// A disparity map (CV_32F [px], negative where none) triangulated in the rectified left camera's frame (x right,
// y down, z forward [m]) with the grey value of the left image, on a regular pixel grid coarse enough for at most
// `max_points`; disparities below `min_disparity_px` left out. The page's "cloud" JSON object.
std::string pointCloudJson(const cv::Mat& disparity, const cv::Mat& grey, double focal_px, double cx, double cy,
                           double baseline_m, size_t max_points, double min_disparity_px, int64_t seq);

struct PageScript {
  std::string marker;  // the placeholder in the template, e.g. "/*@CHART_JS@*/"
  std::string path;    // the file whose text replaces it
};

// Fills the template at `template_path`: every script's marker by that file's text and "/*@REPORT_DATA@*/" by
// `data_json`, and writes the page to `out_path`. Throws naming the file that is missing or lacks its marker.
// The mapper's map for the page's 3D views: world points (every k-th to stay within `max_points`), their grey
// values, the world's up direction and what placed it (words for the page). The page's "map" JSON object.
std::string mapJson(const std::vector<Eigen::Vector3d>& points, const std::vector<uint8_t>& grey, size_t max_points,
                    const Eigen::Vector3d& up, const std::string& placed_by);

void writePage(const std::string& template_path, const std::vector<PageScript>& scripts, const std::string& data_json,
               const std::string& out_path);

// The page's disparity examples: `want` maps spread over the run (among those with a truth, else all), each beside
// its rectified left image (from the input log's STEREO pairs, rectified with `calib`), its truth and its error map;
// the middle one triangulated into the 3D view's cloud. Pairs of another size or invalid are counted in `bad`; a
// damaged input log is named in `failures`.
struct DisparityExamples {
  std::vector<std::string> examples;  // JSON objects, by seq
  std::string cloud = "null";
  int64_t bad = 0;
};
DisparityExamples disparityExamples(const std::string& input_log, const ips::StereoCalibration& calib,
                                    const ips::eval::RunLog& log, const std::vector<ips::eval::DisparityScore>& scores,
                                    int want, double t0, std::vector<std::string>& failures);

// Everything the page draws, as its JSON data: report.json's figures, the trajectories (the truth, each filter on the
// truth, the tracker's chain), the filters' errors with their bounds, the tracker's matches, the processes' latency,
// the disparity examples, the cloud and the map (`map_json`, "null" where none).
std::string pageData(const ips::eval::Json& report, const std::string& run, double t0, const ips::eval::RunLog& log,
                     const ips::eval::FiltersSection& filters, const ips::eval::EstimatorsSection& estimators,
                     const DisparityExamples& examples, const std::string& map_json);

}  // namespace ips::report
