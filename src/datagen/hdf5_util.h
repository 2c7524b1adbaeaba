// Internal: RAII handles and error reporting for the HDF5 C library (recorder only).
#pragma once

#include <hdf5.h>

#include <string>
#include <utility>

#include "mlspaces/core/error.h"

namespace mlspaces::datagen::h5 {

/// Owns one HDF5 identifier and closes it with the matching H5?close.
class Handle {
 public:
  using Closer = herr_t (*)(hid_t);
  Handle() = default;
  Handle(hid_t id, Closer closer) : id_(id), closer_(closer) {}
  Handle(Handle&& o) noexcept : id_(std::exchange(o.id_, H5I_INVALID_HID)), closer_(o.closer_) {}
  Handle& operator=(Handle&& o) noexcept {
    if (this != &o) {
      Reset();
      id_ = std::exchange(o.id_, H5I_INVALID_HID);
      closer_ = o.closer_;
    }
    return *this;
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  ~Handle() { Reset(); }

  hid_t get() const { return id_; }
  /// Closes now; returns false if closing failed (for files: data may not be on disk).
  bool Close() {
    if (id_ < 0) return true;
    const herr_t rc = closer_(id_);
    id_ = H5I_INVALID_HID;
    return rc >= 0;
  }

 private:
  void Reset() {
    if (id_ >= 0) closer_(id_);
    id_ = H5I_INVALID_HID;
  }
  hid_t id_ = H5I_INVALID_HID;
  Closer closer_ = nullptr;
};

/// The innermost message on this thread's HDF5 error stack ("" if none).
inline std::string LastErrorMessage() {
  std::string msg;
  H5Ewalk2(
      H5E_DEFAULT, H5E_WALK_DOWNWARD,
      [](unsigned n, const H5E_error2_t* e, void* data) -> herr_t {
        if (n == 0 && e->desc != nullptr) *static_cast<std::string*>(data) = e->desc;
        return 0;
      },
      &msg);
  return msg;
}

/// Throws Error("<what> failed: <hdf5 message>", path, field) when `id` is negative.
inline hid_t Check(hid_t id, const char* what, const std::string& path, const std::string& field) {
  if (id < 0) {
    std::string msg = LastErrorMessage();
    throw Error(std::string("HDF5 ") + what + " failed" + (msg.empty() ? "" : ": " + msg), path,
                field);
  }
  return id;
}

/// Silences HDF5's automatic error printing on this thread while alive (errors become
/// mlspaces::Error instead), restoring the previous handler afterwards.
class QuietErrors {
 public:
  QuietErrors() {
    H5Eget_auto2(H5E_DEFAULT, &func_, &data_);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  ~QuietErrors() { H5Eset_auto2(H5E_DEFAULT, func_, data_); }
  QuietErrors(const QuietErrors&) = delete;
  QuietErrors& operator=(const QuietErrors&) = delete;

 private:
  H5E_auto2_t func_ = nullptr;
  void* data_ = nullptr;
};

}  // namespace mlspaces::datagen::h5
