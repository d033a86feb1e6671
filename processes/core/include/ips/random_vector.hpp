#pragma once
// Three random numbers as a vector, drawn in a defined order.
// Why: in Eigen::Vector3d(draw(), draw(), draw()) the order of the three calls is unspecified (GCC evaluates a call's
// arguments right to left, clang left to right), so one seed would give another vector under each compiler. Drawn
// z, y, x: GCC's order, the one every simulated world, head and test case so far was drawn in.
#include <Eigen/Core>

namespace ips {

template <class Draw>
Eigen::Vector3d drawVector3(Draw&& draw) {
  const double z = draw();
  const double y = draw();
  const double x = draw();
  return Eigen::Vector3d(x, y, z);
}

}  // namespace ips
