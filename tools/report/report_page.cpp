#include "report_page.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <ips/stereo_pair_t.hpp>
#include <iterator>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <sstream>
#include <stdexcept>

#include "ips/eval/disparity.hpp"
#include "ips/eval/run_report.hpp"
#include "ips/framework/image.hpp"
#include "ips/framework/validate.hpp"

namespace ips::report {

namespace {

// What the page draws per series: enough for a line that looks continuous at a screen's width (a few thousand
// pixels), few enough that the self-contained page stays a few megabytes for a run of hours.
constexpr size_t kMaxPageTrajectoryPoints = 3000;
// The 3D view's point cloud (one disparity map triangulated): enough to see the scene's surfaces, few enough to
// rotate smoothly in a laptop's browser.
constexpr size_t kMaxCloudPoints = 40000;
// Disparities below one pixel are not triangulated: there a quarter-pixel matching error moves the point by more
// than a quarter of its depth.
constexpr double kMinCloudDisparityPx = 1.0;

std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot read");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string base64(const std::vector<uchar>& bytes) {
  static const char* const kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (size_t i = 0; i < bytes.size(); i += 3) {
    const uint32_t b0 = bytes[i], b1 = i + 1 < bytes.size() ? bytes[i + 1] : 0,
                   b2 = i + 2 < bytes.size() ? bytes[i + 2] : 0;
    const uint32_t v = (b0 << 16) | (b1 << 8) | b2;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? kAlphabet[(v >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? kAlphabet[v & 63] : '=';
  }
  return out;
}

// Replaces the one occurrence of `marker` in `page` by `text`.
void fill(std::string& page, const std::string& marker, const std::string& text, const std::string& template_path) {
  const size_t at = page.find(marker);
  if (at == std::string::npos) throw std::runtime_error(template_path + ": has no placeholder " + marker);
  page.replace(at, marker.size(), text);
}

}  // namespace

std::string jsonArray(const std::vector<double>& values, int digits) {
  std::ostringstream os;
  os << std::setprecision(digits) << '[';
  for (size_t i = 0; i < values.size(); ++i) {
    if (i) os << ',';
    if (std::isfinite(values[i]))
      os << values[i];
    else
      os << "null";
  }
  os << ']';
  return os.str();
}

std::string jsonString(const std::string& value) {
  std::string o = "\"";
  for (char c : value) {
    if (c == '"' || c == '\\') o += '\\';
    if (static_cast<unsigned char>(c) < 0x20) c = ' ';
    // Inside the page's <script> element "</script" would end it: '<' goes escaped.
    if (c == '<') {
      o += "\\u003c";
      continue;
    }
    o += c;
  }
  return o + "\"";
}

std::string pngDataUri(const cv::Mat& image) {
  std::vector<uchar> png;
  if (!cv::imencode(".png", image, png)) throw std::runtime_error("cannot encode a report picture as PNG");
  return "data:image/png;base64," + base64(png);
}

cv::Mat colourMapped(const cv::Mat& values, double vmin, double vmax, int colormap, const cv::Mat& marked,
                     const cv::Scalar& marked_bgr) {
  cv::Mat u8;
  const double span = std::max(1e-9, vmax - vmin);
  values.convertTo(u8, CV_8U, 255.0 / span, -vmin * 255.0 / span);  // saturates at 0 and 255
  cv::Mat colour;
  cv::applyColorMap(u8, colour, colormap);
  if (!marked.empty()) colour.setTo(marked_bgr, marked);
  return colour;
}

std::string colourBarDataUri(int colormap) {
  cv::Mat ramp(1, 256, CV_8U);
  for (int i = 0; i < 256; ++i) ramp.at<uchar>(0, i) = static_cast<uchar>(i);
  cv::Mat colour;
  cv::applyColorMap(ramp, colour, colormap);
  return pngDataUri(colour);
}

std::string cssColour(const cv::Scalar& bgr) {
  char s[8];
  std::snprintf(s, sizeof s, "#%02x%02x%02x", static_cast<int>(bgr[2]), static_cast<int>(bgr[1]),
                static_cast<int>(bgr[0]));
  return s;
}

std::string colourMapsJson(const DisparityColours& colours) {
  return "{\"disparity\": \"" + colourBarDataUri(cv::COLORMAP_TURBO) + "\", \"error\": \"" +
         colourBarDataUri(cv::COLORMAP_INFERNO) + "\", \"invalid\": \"" + cssColour(colours.invalid) +
         "\", \"not_evaluated\": \"" + cssColour(colours.not_evaluated) + "\", \"no_estimate\": \"" +
         cssColour(colours.no_estimate) + "\"}";
}

std::string disparityExampleJson(const cv::Mat& left, const cv::Mat& estimate, const cv::Mat& truth, double dmin,
                                 double dmax, double error_max, const std::string& fields,
                                 const DisparityColours& colours) {
  const cv::Mat est_invalid = estimate < 0;
  std::ostringstream e;
  e << std::setprecision(6) << "{\"width\": " << estimate.cols << ", \"height\": " << estimate.rows
    << ", \"disparity_min\": " << dmin << ", \"disparity_max\": " << dmax << ", \"error_max\": " << error_max
    << ", \"left\": \"" << pngDataUri(left) << "\", \"estimate\": \""
    << pngDataUri(colourMapped(estimate, dmin, dmax, cv::COLORMAP_TURBO, est_invalid, colours.invalid)) << "\"";
  if (!truth.empty()) {
    const cv::Mat gt_invalid = truth < 0;
    cv::Mat err;
    cv::absdiff(estimate, truth, err);
    cv::Mat err_colour = colourMapped(err, 0, error_max, cv::COLORMAP_INFERNO, gt_invalid, colours.not_evaluated);
    err_colour.setTo(colours.no_estimate, est_invalid & ~gt_invalid);
    e << ", \"truth\": \""
      << pngDataUri(colourMapped(truth, dmin, dmax, cv::COLORMAP_TURBO, gt_invalid, colours.invalid))
      << "\", \"error\": \"" << pngDataUri(err_colour) << "\"";
  }
  e << fields << "}";
  return e.str();
}

std::string pointCloudJson(const cv::Mat& disparity, const cv::Mat& grey, double focal_px, double cx, double cy,
                           double baseline_m, size_t max_points, double min_disparity_px, int64_t seq) {
  const int valid = cv::countNonZero(disparity >= min_disparity_px);
  const int stride = std::max(1, static_cast<int>(std::ceil(std::sqrt(valid / static_cast<double>(max_points)))));
  std::vector<double> xyz, grey_values;
  for (int r = stride / 2; r < disparity.rows; r += stride)
    for (int c = stride / 2; c < disparity.cols; c += stride) {
      const float d = disparity.at<float>(r, c);
      if (d < min_disparity_px) continue;
      const double z = focal_px * baseline_m / d;
      xyz.push_back((c - cx) * z / focal_px);
      xyz.push_back((r - cy) * z / focal_px);
      xyz.push_back(z);
      grey_values.push_back(grey.at<uchar>(r, c));
    }
  return "{\"seq\": " + std::to_string(seq) + ", \"points\": " + std::to_string(grey_values.size()) +
         ", \"stride_px\": " + std::to_string(stride) + ", \"xyz\": " + jsonArray(xyz, 4) +
         ", \"grey\": " + jsonArray(grey_values, 3) + "}";
}

std::string mapJson(const std::vector<Eigen::Vector3d>& points, const std::vector<uint8_t>& grey, size_t max_points,
                    const Eigen::Vector3d& up, const std::string& placed_by) {
  std::vector<double> xyz, grey_values;
  for (size_t i : ips::eval::subsample(points.size(), max_points)) {
    for (int k = 0; k < 3; ++k) xyz.push_back(points[i][k]);
    grey_values.push_back(i < grey.size() ? grey[i] : 0);
  }
  return "{\"points\": " + std::to_string(grey_values.size()) + ", \"voxels\": " + std::to_string(points.size()) +
         ", \"up\": " + jsonArray({up.x(), up.y(), up.z()}) + ", \"placed_by\": " + jsonString(placed_by) +
         ", \"xyz\": " + jsonArray(xyz, 5) + ", \"grey\": " + jsonArray(grey_values, 3) + "}";
}

void writePage(const std::string& template_path, const std::vector<PageScript>& scripts, const std::string& data_json,
               const std::string& out_path) {
  std::string page = readFile(template_path);
  // The data first: the libraries' text may contain anything, the data block only what this tool wrote.
  fill(page, "/*@REPORT_DATA@*/", data_json, template_path);
  for (const auto& s : scripts) {
    std::string text = readFile(s.path);
    if (text.find("</script") != std::string::npos)
      throw std::runtime_error(s.path + ": contains \"</script\" and cannot be inlined into the page");
    fill(page, s.marker, text, template_path);
  }
  std::ofstream out(out_path, std::ios::binary);
  out << page;
  out.close();
  if (!out) throw std::runtime_error(out_path + ": cannot write (disk full?)");
}

DisparityExamples disparityExamples(const std::string& input_log, const ips::StereoCalibration& calib,
                                    const ips::eval::RunLog& log, const std::vector<ips::eval::DisparityScore>& scores,
                                    int want, double t0, std::vector<std::string>& failures) {
  DisparityExamples out;
  const ips::StereoRectification rect = ips::computeRectification(calib);
  // Spread over the run: among the maps with ground truth, or all maps when there is none (a recording).
  std::vector<int64_t> candidates;
  for (const auto& sc : scores) candidates.push_back(sc.seq);
  if (candidates.empty())
    for (const auto& kv : log.est_disp) candidates.push_back(kv.second.seq);
  std::set<int64_t> pick;
  for (int i = 0; i < want && i < static_cast<int>(candidates.size()); ++i)
    pick.insert(candidates[candidates.size() * (2 * i + 1) / (2 * want)]);
  const int64_t cloud_seq = pick.empty() ? -1 : *std::next(pick.begin(), static_cast<long>(pick.size() / 2));
  std::map<int64_t, const ips::eval::DisparityScore*> score_of;
  for (const auto& sc : scores) score_of[sc.seq] = &sc;
  std::map<int64_t, std::string> examples;  // by seq, in order
  ips::eval::forEachMessage(input_log, failures, [&](const ips::fw::LogMessage& im) {
    if (im.channel != "STEREO") return;
    ips::stereo_pair_t p;
    if (p.decode(im.data.data(), 0, static_cast<int>(im.data.size())) < 0 || !pick.count(p.seq) ||
        !log.est_disp.count(p.utime) || examples.count(p.seq))
      return;
    if (!ips::fw::validate(p).ok() || p.width != calib.cam0.width || p.height != calib.cam0.height) {
      ++out.bad;
      return;
    }
    cv::Mat r0, r1;
    ips::rectifyPair(rect, ips::fw::leftImage(p), ips::fw::rightImage(p), r0, r1);
    const ips::disparity_map_t& dm = log.est_disp.at(p.utime);
    // The page draws values below zero as "none".
    cv::Mat d = ips::fw::disparityImage(dm);
    cv::patchNaNs(d, -1.0);
    cv::resize(r0, r0, d.size(), 0, 0, cv::INTER_AREA);
    cv::Mat truth;
    if (const auto g = log.gt_disp.find(p.utime); g != log.gt_disp.end()) {  // at the map's scale, as scored
      truth = ips::eval::truthAtSize(ips::fw::disparityImage(g->second), d.size());
      cv::patchNaNs(truth, -1.0);
    }
    ips::eval::Json fields;
    fields["seq"] = p.seq;
    fields["t"] = ips::eval::figure(p.utime * 1e-6 - t0);
    if (score_of.count(p.seq)) {
      const ips::eval::DisparityScore& sc = *score_of[p.seq];
      fields["bad2_pct"] = ips::eval::figure(sc.bad2_pct);
      fields["density_pct"] = ips::eval::figure(sc.density_pct);
      fields["evaluated"] = sc.evaluated;
    }
    // disparityExampleJson takes its extra members each with a leading ", ".
    std::string members = fields.dump();
    members = ", " + members.substr(1, members.size() - 2);
    examples[p.seq] = disparityExampleJson(r0, d, truth, dm.min_disparity, dm.min_disparity + dm.num_disparities,
                                           2 * ips::eval::kBadDisparityPx, members);
    if (p.seq == cloud_seq && dm.focal_px > 0 && dm.baseline_m > 0)
      out.cloud =
          pointCloudJson(d, r0, dm.focal_px, dm.cx, dm.cy, dm.baseline_m, kMaxCloudPoints, kMinCloudDisparityPx, p.seq);
  });
  for (const auto& kv : examples) out.examples.push_back(kv.second);
  return out;
}

std::string pageData(const ips::eval::Json& report, const std::string& run, double t0, const ips::eval::RunLog& log,
                     const ips::eval::FiltersSection& filters, const ips::eval::EstimatorsSection& estimators,
                     const DisparityExamples& examples, const std::string& map_json) {
  using ips::eval::Trajectory;
  std::vector<std::string> trajectories, errors;
  auto trajectory = [&](const std::string& name, const std::string& kind, const Trajectory& tr) {
    std::vector<double> t, x, y, z;
    for (size_t i : ips::eval::subsample(tr.size(), kMaxPageTrajectoryPoints)) {
      t.push_back(tr[i].t - t0);
      x.push_back(tr[i].p.x()), y.push_back(tr[i].p.y()), z.push_back(tr[i].p.z());
    }
    trajectories.push_back("{\"name\": " + jsonString(name) + ", \"kind\": \"" + kind + "\", \"poses\": " +
                           std::to_string(tr.size()) + ", \"t\": " + jsonArray(t, 7) + ", \"x\": " + jsonArray(x, 6) +
                           ", \"y\": " + jsonArray(y, 6) + ", \"z\": " + jsonArray(z, 6) + "}");
  };
  if (!log.gt.empty()) trajectory("ground truth", "truth", log.gt);
  for (const auto& f : filters.results) {
    if (f.aligned.empty()) continue;
    const std::string label = (f.name == "ukf" ? "UKF (" : "EKF (") + f.channel + ")";
    trajectory(label, f.name, f.aligned);
    const ips::eval::ErrorSeries& err = f.errors;
    std::ostringstream e;
    e << "{\"name\": " << jsonString(label) << ", \"kind\": \"" << f.name << "\", \"t\": " << jsonArray(err.t, 7)
      << ", \"nees\": " << jsonArray(err.nees, 4);
    const char* keys[] = {"pos", "pos3s", "att", "att3s"};
    const std::array<std::vector<double>, 3>* series[] = {&err.pos, &err.pos3s, &err.att, &err.att3s};
    for (int k = 0; k < 4; ++k) {
      e << ", \"" << keys[k] << "\": [";
      for (int a = 0; a < 3; ++a) e << (a ? "," : "") << jsonArray((*series[k])[a], 4);
      e << "]";
    }
    e << "}";
    errors.push_back(e.str());
  }
  if (!log.delta_msgs.empty())
    trajectory("tracker (camera 0, chained increments)", "tracker", estimators.tracker_on_truth);

  std::vector<double> t, inliers, matches, valid;
  for (size_t i : ips::eval::subsample(log.delta_msgs.size(), kMaxPageErrorSamples)) {
    const ips::tracker_delta_t& d = log.delta_msgs[i];
    t.push_back(d.utime * 1e-6 - t0);
    inliers.push_back(d.num_inliers);
    matches.push_back(d.num_inter_matches);
    valid.push_back(d.valid ? 1 : 0);
  }
  std::string latency = "[";
  for (const auto& [process, f] : log.procs) {
    if (f.t.empty()) continue;  // a process that reports no processing time (the filters)
    std::vector<double> ft, fl, fr;
    for (size_t i : ips::eval::subsample(f.t.size(), kMaxPageErrorSamples)) {
      ft.push_back(f.t[i] - t0);
      fl.push_back(f.latency_ms[i]);
      fr.push_back(f.rate_hz[i]);
    }
    latency += (latency.size() > 1 ? ", " : "") + std::string("{\"process\": ") + jsonString(process) +
               ", \"t\": " + jsonArray(ft, 7) + ", \"latency_ms\": " + jsonArray(fl, 4) +
               ", \"rate_hz\": " + jsonArray(fr, 4) + "}";
  }
  auto list = [](const std::vector<std::string>& items) {
    std::string o = "[";
    for (size_t i = 0; i < items.size(); ++i) o += (i ? ",\n" : "\n") + items[i];
    return o + "]";
  };
  // The report inside a <script>: no "</script>" may close it early, whatever a process named itself or its counters.
  std::string report_text = report.dump(-1, ' ', false, ips::eval::Json::error_handler_t::replace);
  for (size_t at = report_text.find('<'); at != std::string::npos; at = report_text.find('<', at))
    report_text.replace(at, 1, "\\u003c");
  std::ostringstream data;
  data << "{\"report\": " << report_text << ", \"run\": " << jsonString(run)
       << ", \"t0\": " << ips::eval::figure(t0).dump() << ", \"trajectories\": " << list(trajectories)
       << ", \"errors\": " << list(errors) << ", \"nees_band\": [" << ips::eval::figure(ips::eval::kChi2Dof3Lo).dump()
       << ", " << ips::eval::figure(ips::eval::kChi2Dof3Hi).dump() << "], \"tracker\": {\"t\": " << jsonArray(t, 7)
       << ", \"inliers\": " << jsonArray(inliers) << ", \"inter_matches\": " << jsonArray(matches)
       << ", \"valid\": " << jsonArray(valid) << "}, \"latency\": " << latency << "]"
       << ", \"disparity\": " << list(examples.examples) << ", \"colour_maps\": " << colourMapsJson()
       << ", \"cloud\": " << examples.cloud << ", \"map\": " << map_json << "}";
  return data.str();
}

}  // namespace ips::report
