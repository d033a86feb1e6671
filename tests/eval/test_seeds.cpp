// The summary over seeds (ips/eval/seeds.hpp) against hand-computed figures and against chi-square draws: a consistent
// filter's NEES averaged over ten seeds stays inside the 95 % band in about 95 % of the seconds; an overconfident
// one's does not.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>

#include "ips/eval/seeds.hpp"

using ips::eval::SeedFilterRun;

namespace {

SeedFilterRun constantRun(double end_pct, double nees, double seconds) {
  SeedFilterRun r;
  r.end_error_pct = end_pct;
  r.end_error_m = end_pct;  // any number: its mean is checked
  r.ate_rmse_m = 2 * end_pct;
  for (int k = 0; k * 0.1 <= seconds + 1e-9; ++k) {
    r.t.push_back(k * 0.1);
    r.nees.push_back(nees);
  }
  return r;
}

}  // namespace

TEST(Seeds, EndErrorMeanWorstAndSpread) {
  const ips::eval::SeedSummary s = ips::eval::summariseSeeds({constantRun(0.1, 3, 10), constantRun(0.3, 3, 10)});
  EXPECT_EQ(s.seeds, 2);
  EXPECT_NEAR(s.end_error_pct_mean, 0.2, 1e-12);
  EXPECT_NEAR(s.end_error_pct_worst, 0.3, 1e-12);
  EXPECT_NEAR(s.end_error_pct_std, std::sqrt(0.02), 1e-12);  // sample standard deviation of {0.1, 0.3}
  EXPECT_NEAR(s.ate_rmse_m_mean, 0.4, 1e-12);
  // Chi-square with 6 dof, 2.5 % and 97.5 % quantiles 1.2373 and 14.4494, over 2 seeds.
  EXPECT_NEAR(s.band_lo, 1.2373 / 2, 1e-3);
  EXPECT_NEAR(s.band_hi, 14.4494 / 2, 1e-3);
  EXPECT_EQ(s.nees_t.size(), 10u);  // whole seconds 1..10
  EXPECT_NEAR(s.anees, 3.0, 1e-12);
  EXPECT_NEAR(s.in_band_pct, 100.0, 1e-12);
  // The seconds every run covers; NaN (no covariance) leaves a second out.
  SeedFilterRun shorter = constantRun(0.2, 20, 5.05);
  shorter.nees[30] = NAN;  // t = 3 s
  const ips::eval::SeedSummary t = ips::eval::summariseSeeds({constantRun(0.1, 20, 10), shorter});
  EXPECT_EQ(t.nees_t, (std::vector<double>{1, 2, 4, 5}));
  EXPECT_NEAR(t.in_band_pct, 0.0, 1e-12);  // NEES 20 is far above the band
  EXPECT_THROW(ips::eval::summariseSeeds({}), std::invalid_argument);
}

TEST(Seeds, ConsistentNeesStaysInItsBandAboutNinetyFivePercentOfTheTime) {
  std::mt19937 rng(5);
  std::chi_squared_distribution<double> chi3(3.0);
  for (double scale : {1.0, 3.0}) {  // 3: a filter whose covariance is three times too small
    std::vector<SeedFilterRun> runs(10);
    for (SeedFilterRun& r : runs)
      for (int k = 0; k <= 2000; ++k) {
        r.t.push_back(k);
        r.nees.push_back(scale * chi3(rng));
      }
    const ips::eval::SeedSummary s = ips::eval::summariseSeeds(runs);
    if (scale == 1.0) {
      EXPECT_NEAR(s.in_band_pct, 95.0, 2.0);
      EXPECT_NEAR(s.anees, 3.0, 0.1);
    } else {
      EXPECT_LT(s.in_band_pct, 5.0);
      EXPECT_NEAR(s.anees, 9.0, 0.3);
    }
  }
}

TEST(Seeds, NeesFilesAreReadAndBadLinesNamed) {
  const std::string path = testing::TempDir() + "/nees_FILTER_STATE.tsv";
  {
    std::ofstream f(path);
    f << "# t nees\n0.5 3.25\n1.0 nan\n1.5 2.5\n";
  }
  std::vector<double> t, nees;
  ips::eval::readNeesSeries(path, t, nees);
  ASSERT_EQ(t.size(), 3u);
  EXPECT_EQ(t[2], 1.5);
  EXPECT_EQ(nees[0], 3.25);
  EXPECT_TRUE(std::isnan(nees[1]));
  {
    std::ofstream f(path);
    f << "0.5 3.25\n0.4 2\n";
  }
  try {
    ips::eval::readNeesSeries(path, t, nees);
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("nees_FILTER_STATE.tsv:2"), std::string::npos) << e.what();
  }
  {
    std::ofstream f(path);
    f << "0.5 3.25x\n";
  }
  EXPECT_THROW(ips::eval::readNeesSeries(path, t, nees), std::runtime_error);
  EXPECT_THROW(ips::eval::readNeesSeries(path + ".missing", t, nees), std::runtime_error);
}
