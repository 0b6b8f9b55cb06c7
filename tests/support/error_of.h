#pragma once
// The message of the sahbench::Error a call throws, for tests of error messages.

#include <gtest/gtest.h>

#include <string>

#include "core/error.h"

namespace sahbench::test {

/// The Error `f` throws; the test fails when it throws none.
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "no Error thrown";
  return "";
}

}  // namespace sahbench::test
