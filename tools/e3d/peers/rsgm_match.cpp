// Harness for rSGM (Spangenberg et al. 2014; kbatsos/Real-Time-Stereo, folder CPU/sgm), the CPU matcher E3D is
// measured against. rSGM's code stays outside the project, and so does its build: compile this file together with
// the CPU/sgm sources of a checkout of your own (AVX2, OpenMP, OpenCV; rSGM's sources use AVX2 intrinsics without
// including immintrin.h). Not part of the CMake build (CI has no rSGM).
//   rsgm_match LEFT RIGHT NDISP OUT.pfm            one match, PFM (inf = invalid), for e3d_eval --peer-cmd
//   rsgm_match --bench LEFT RIGHT NDISP W H RUNS   fps of the whole match (census, costs, SGM, checks) at W x H
// Settings: rSGM's published census SGM (census 5x5, 8 paths in two passes, P1 7, P2 = max(17, 50 - 0.25 |dI|),
// uniqueness 0.95, median, left-right check "1 px" (rSGM truncates the difference), parabolic subpixel
// (RSGM_SUBPIX=-1 turns it off, 1 picks rSGM's other method)), the two cores as two strips.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "FastFilters.h"
#include "StereoBMHelper.h"
#include "StereoSGM.h"

namespace {

const int kThreads = 2;       // this machine's cores; rSGM splits the image into as many strips
const int kStripBorder = 16;  // rows each strip matches beyond its own (rSGM's example value)

struct Rsgm {
  int width, height, num_disp;
  StereoSGMParams_t params;
  uint32 *census_left, *census_right;
  uint16* dsi;
  float32 *disp_left, *disp_right;
  StripedStereoSGM<uint8>* sgm;

  Rsgm(int w, int h, int nd) : width(w), height(h), num_disp(nd) {
    params.P1 = 7;
    params.P2min = 17;
    params.Gamma = 50;
    params.Alpha = 0.25f;
    params.NoPasses = 2;
    params.Paths = 8;
    params.Uniqueness = 0.95f;
    params.MedianFilter = true;
    params.lrCheck = true;
    params.lrThreshold = 1;
    params.subPixelRefine = getenv("RSGM_SUBPIX") ? atoi(getenv("RSGM_SUBPIX")) : 0;
    census_left = static_cast<uint32*>(_mm_malloc(size_t(w) * h * 4, 16));
    census_right = static_cast<uint32*>(_mm_malloc(size_t(w) * h * 4, 16));
    dsi = static_cast<uint16*>(_mm_malloc(size_t(w) * h * nd * 2, 32));
    disp_left = static_cast<float32*>(_mm_malloc(size_t(w) * h * 4, 16));
    disp_right = static_cast<float32*>(_mm_malloc(size_t(w) * h * 4, 16));
    sgm = new StripedStereoSGM<uint8>(w, h, nd - 1, kThreads, kStripBorder, params);
  }

  void match(const cv::Mat& left, const cv::Mat& right) {
    census5x5_SSE(left.data, census_left, width, height);
    census5x5_SSE(right.data, census_right, width, height);
    costMeasureCensus5x5_xyd_SSE(census_left, census_right, height, width, num_disp, params.InvalidDispCost, dsi,
                                 kThreads);
    sgm->process(left.data, disp_left, disp_right, dsi, kThreads, 0);
  }
};

int usage() {
  fprintf(stderr,
          "usage: rsgm_match LEFT RIGHT NDISP OUT.pfm\n"
          "       rsgm_match --bench LEFT RIGHT NDISP W H RUNS\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  const bool bench = argc > 1 && !strcmp(argv[1], "--bench");
  if (argc != (bench ? 8 : 5)) return usage();
  const int a = bench ? 2 : 1;
  cv::Mat left = cv::imread(argv[a], cv::IMREAD_GRAYSCALE), right = cv::imread(argv[a + 1], cv::IMREAD_GRAYSCALE);
  if (left.empty() || right.empty() || left.size() != right.size()) {
    fprintf(stderr, "rsgm_match: cannot read two images of one size\n");
    return 1;
  }
  fillPopCount16LUT();
  // rSGM's vectors hold 16 disparities.
  const int num_disp = (atoi(argv[a + 2]) + 15) / 16 * 16;
  if (bench) {
    const int w = atoi(argv[a + 3]), h = atoi(argv[a + 4]), runs = atoi(argv[a + 5]);
    cv::resize(left, left, {w, h}, 0, 0, cv::INTER_AREA);
    cv::resize(right, right, {w, h}, 0, 0, cv::INTER_AREA);
    Rsgm rsgm(w, h, num_disp);
    rsgm.match(left, right);  // warm-up
    double best = 1e9, total = 0;
    for (int i = 0; i < runs; ++i) {
      const auto t0 = std::chrono::steady_clock::now();
      rsgm.match(left, right);
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      best = std::min(best, s);
      total += s;
    }
    printf("rsgm %dx%d ndisp %d: best %.2f fps, mean %.2f fps over %d runs\n", w, h, num_disp, 1 / best, runs / total,
           runs);
    return 0;
  }
  // rSGM's SSE code needs a width divisible by 16: pad by repeating the last column, crop the map back.
  const int w0 = left.cols, w = (w0 + 15) / 16 * 16, h = left.rows;
  cv::copyMakeBorder(left, left, 0, 0, 0, w - w0, cv::BORDER_REPLICATE);
  cv::copyMakeBorder(right, right, 0, 0, 0, w - w0, cv::BORDER_REPLICATE);
  Rsgm rsgm(w, h, num_disp);
  rsgm.match(left, right);
  cv::Mat out(h, w0, CV_32F);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w0; ++x) {
      const float d = rsgm.disp_left[y * w + x];
      out.at<float>(y, x) = (d < 0 || d > num_disp) ? std::numeric_limits<float>::infinity() : d;
    }
  return cv::imwrite(argv[a + 3], out) ? 0 : 1;
}
