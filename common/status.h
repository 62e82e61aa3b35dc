// Error handling for library code: absl::Status / absl::StatusOr (docs/architecture.md,
// "Conventions").
// Services map these to grpc::Status; CHECK-style aborts are for internal invariants only.
#pragma once

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"

namespace loci {

using Status = absl::Status;
template <typename T>
using StatusOr = absl::StatusOr<T>;

// Returns from the enclosing function when `expr` (an absl::Status) is not OK.
#define LOCI_RETURN_IF_ERROR(expr)            \
  do {                                        \
    ::absl::Status loci_status_ = (expr);     \
    if (!loci_status_.ok()) return loci_status_; \
  } while (0)

#define LOCI_CONCAT_INNER_(a, b) a##b
#define LOCI_CONCAT_(a, b) LOCI_CONCAT_INNER_(a, b)
// Assigns the value of a StatusOr to `lhs`, or returns its error.
#define LOCI_ASSIGN_OR_RETURN(lhs, expr) \
  LOCI_ASSIGN_OR_RETURN_IMPL_(LOCI_CONCAT_(loci_statusor_, __LINE__), lhs, expr)
#define LOCI_ASSIGN_OR_RETURN_IMPL_(tmp, lhs, expr) \
  auto tmp = (expr);                                \
  if (!tmp.ok()) return tmp.status();               \
  lhs = std::move(tmp).value()

}  // namespace loci
