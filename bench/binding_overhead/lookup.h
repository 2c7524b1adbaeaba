// The call shapes the library API makes, bound the same way with nanobind and pybind11
// (bench/binding_overhead.sh): a method taking a str and returning a tuple (locate), one
// returning a small dict (annotation), a no-op.
#pragma once

#include <string>
#include <unordered_map>

struct Table {
  std::unordered_map<std::string, std::string> paths;
  Table() {
    for (int i = 0; i < 1000; ++i) {
      paths["uid_" + std::to_string(i)] = "/data/lib/uid_" + std::to_string(i) + ".xml";
    }
  }
  const std::string* Find(const std::string& uid) const {
    auto it = paths.find(uid);
    return it == paths.end() ? nullptr : &it->second;
  }
};
