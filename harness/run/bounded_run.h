#pragma once
// Work with a time bound, for builds that might not terminate on adversarial input: the stress suite
// must record such a build as failed and go on, not hang. C++ cannot stop a thread, so work still
// running at the bound is abandoned: its thread is detached and runs on (or forever) beside the
// caller, who should end the process without waiting for it (the CLI does, with quick_exit).

#include <chrono>
#include <exception>
#include <future>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <utility>

namespace sahbench {

template <class T>
struct BoundedResult {
  std::optional<T> value;  ///< the work's result, when it finished in time without throwing
  std::string error;       ///< the exception's message, when it threw
  bool timed_out = false;  ///< still running at the bound: abandoned
};

/// Runs `work()` on a thread of its own and waits up to `limit_s` seconds. `work` must own everything it
/// uses (capture by value or shared_ptr): once abandoned, it outlives the caller's stack.
template <class T, class Work>
BoundedResult<T> run_bounded(Work work, double limit_s) {
  auto task = std::make_shared<std::packaged_task<T()>>(std::move(work));
  std::future<T> result = task->get_future();
  std::thread worker([task] { (*task)(); });
  BoundedResult<T> out;
  if (result.wait_for(std::chrono::duration<double>(limit_s)) != std::future_status::ready) {
    worker.detach();
    out.timed_out = true;
    return out;
  }
  worker.join();
  try {
    out.value.emplace(result.get());
  } catch (const std::exception& e) {
    out.error = e.what();
  } catch (...) {
    out.error = "an exception that is not a std::exception";
  }
  return out;
}

}  // namespace sahbench
