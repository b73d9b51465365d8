// PythonProgress: the library's progress reports, forwarded to a Python callable.
#include <algorithm>
#include <string>
#include <utility>

#include "bindings.hpp"

namespace strata::python {

namespace {

// Often enough for a smooth bar, rarely enough that taking the GIL costs nothing measurable.
constexpr std::chrono::milliseconds kReportInterval{100};

}  // namespace

PythonProgress::PythonProgress(py::handle progress) {
  if (progress.is_none() || (py::isinstance<py::bool_>(progress) && !progress.cast<bool>())) return;
  if (py::isinstance<py::bool_>(progress)) {
    callback_ = py::module_::import("strata._progress").attr("ProgressBar")();
    return;
  }
  if (!PyCallable_Check(progress.ptr()))
    throw py::type_error("progress: expected True, False, None or a callable progress(task, done, total), got " +
                         std::string(py::repr(progress)));
  callback_ = py::reinterpret_borrow<py::object>(progress);
}

PythonProgress::~PythonProgress() {
  py::gil_scoped_acquire gil;
  callback_ = py::object();
  error_ = nullptr;
}

void PythonProgress::begin(std::string_view task, std::uint64_t total, std::string_view) {
  {
    std::lock_guard lock(mutex_);
    task_ = std::string(task);
    total_ = total;
  }
  done_ = 0;
  report(true);
}

void PythonProgress::advance(std::uint64_t units) {
  done_ += units;
  report(false);
}

void PythonProgress::end() { report(true); }

void PythonProgress::report(bool force) {
  if (!callback_ || std::this_thread::get_id() != owner_) return;
  const auto now = std::chrono::steady_clock::now();
  if (!force && now - last_ < kReportInterval) return;
  last_ = now;
  std::string task;
  std::uint64_t total = 0;
  {
    std::lock_guard lock(mutex_);
    task = task_;
    total = total_;
  }
  py::gil_scoped_acquire gil;
  if (error_) return;
  try {
    const std::uint64_t done = done_.load();
    callback_(task, total > 0 ? std::min(done, total) : done, total);
  } catch (py::error_already_set&) {
    // Never thrown through the library (it may be inside a parallel loop): raised afterwards.
    error_ = std::current_exception();
  }
}

void PythonProgress::rethrow() {
  if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
}

}  // namespace strata::python
