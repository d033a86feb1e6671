#include "ips/calib/figures.hpp"

#include <ctime>

namespace ips::calib {
namespace {

// Writes a node's value (the key, if any, is already written): maps and sequences recursively, scalars as they are.
void copyValue(cv::FileStorage& out, const cv::FileNode& node) {
  if (node.isMap()) {
    out << "{";
    for (const cv::FileNode& child : node) {
      out << child.name();
      copyValue(out, child);
    }
    out << "}";
  } else if (node.isSeq()) {
    out << "[";
    for (const cv::FileNode& item : node) copyValue(out, item);
    out << "]";
  } else if (node.isInt()) {
    out << static_cast<int>(node);
  } else if (node.isReal()) {
    out << static_cast<double>(node);
  } else if (node.isString()) {
    out << static_cast<std::string>(node);
  }
}

bool endsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

}  // namespace

void copyFigureBlocks(cv::FileStorage& out, const std::string& previous, const std::string& except) {
  cv::FileStorage in;
  try {
    if (!in.open(previous, cv::FileStorage::READ)) return;
  } catch (const cv::Exception&) {
    return;
  }
  for (const cv::FileNode& node : in.root()) {
    if (!endsWith(node.name(), "_figures") || node.name() == except) continue;
    out << node.name();
    copyValue(out, node);
  }
}

std::string utcNow() {
  char date[32];
  const std::time_t now = std::time(nullptr);
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  return date;
}

}  // namespace ips::calib
