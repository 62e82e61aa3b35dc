// Options declared once: each section of a component's options is a table of rows (YAML key,
// the field it fills, bounds, one doc line). The YAML reader, the unknown-key check, the bounds
// check and the documentation (`loci-server --print-options`, docs) all come from that table, so
// a default, its bounds and its doc line cannot drift apart.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <span>
#include <type_traits>
#include <string>
#include <variant>
#include <vector>

#include "common/config.h"
#include "common/status.h"

namespace loci {

// One option of options struct T: a scalar (double, int, bool) or a list of names.
template <typename T>
struct OptionRow {
  using Field = std::variant<double T::*, int T::*, bool T::*, std::vector<std::string> T::*>;
  const char* key;
  Field field;
  double lo = 0, hi = 0;  // inclusive bounds of numbers (ignored for bools and lists)
  const char* doc = "";
};

template <typename T>
using OptionTable = std::span<const OptionRow<T>>;

namespace option_table_internal {

inline std::string FormatNumber(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%g", v);
  return buf;
}

template <typename T>
std::string ValueText(const OptionRow<T>& row, const T& o) {
  return std::visit(
      [&](auto member) -> std::string {
        using V = std::decay_t<decltype(o.*member)>;
        if constexpr (std::is_same_v<V, bool>) {
          return (o.*member) ? "true" : "false";
        } else if constexpr (std::is_same_v<V, std::vector<std::string>>) {
          std::string s = "[";
          for (size_t i = 0; i < (o.*member).size(); ++i) s += (i ? ", " : "") + (o.*member)[i];
          return s + "]";
        } else {
          return FormatNumber(static_cast<double>(o.*member));
        }
      },
      row.field);
}

}  // namespace option_table_internal

// Bounds of every number of `table` in `o`: InvalidArgument naming section.key and the range.
template <typename T>
Status CheckOptionTable(const std::string& section, std::type_identity_t<OptionTable<T>> table, const T& o) {
  for (const OptionRow<T>& row : table) {
    double v = 0;
    if (const auto* d = std::get_if<double T::*>(&row.field)) {
      v = o.**d;
    } else if (const auto* i = std::get_if<int T::*>(&row.field)) {
      v = o.**i;
    } else {
      continue;
    }
    if (!(std::isfinite(v) && v >= row.lo && v <= row.hi)) {
      return absl::InvalidArgumentError(absl::StrCat(
          section, ".", row.key, " must be in [", option_table_internal::FormatNumber(row.lo),
          ", ", option_table_internal::FormatNumber(row.hi), "], is ",
          option_table_internal::FormatNumber(v)));
    }
  }
  return absl::OkStatus();
}

// Reads the keys of `table` present in `node` into *out, after checking that `node` holds no
// other key (besides `nested`, sections read elsewhere), then checks every number's bounds.
// `section` names the section in errors ("map.fusion").
template <typename T>
Status ReadOptionTable(const YAML::Node& node, const std::string& section, std::type_identity_t<OptionTable<T>> table,
                       T* out, std::initializer_list<const char*> nested = {}) {
  if (node && node.IsMap()) {
    std::vector<const char*> known;
    for (const OptionRow<T>& row : table) known.push_back(row.key);
    known.insert(known.end(), nested.begin(), nested.end());
    LOCI_RETURN_IF_ERROR(CheckKnownKeys(node, section, std::span<const char* const>(known)));
  }
  for (const OptionRow<T>& row : table) {
    LOCI_RETURN_IF_ERROR(std::visit(
        [&](auto member) { return ReadOptional(node, row.key, &(out->*member)); }, row.field));
  }
  return CheckOptionTable(section, table, *out);
}

// The section as YAML with the defaults of `o` and each row's doc line as a comment, indented
// by `indent` spaces: what docs and the shipped YAML show.
template <typename T>
std::string OptionTableYaml(std::type_identity_t<OptionTable<T>> table, const T& o, int indent) {
  std::string out;
  const std::string pad(indent, ' ');
  for (const OptionRow<T>& row : table) {
    out += pad + row.key + ": " + option_table_internal::ValueText(row, o) + "  # " + row.doc +
           "\n";
  }
  return out;
}

// The default value of one key of `table` as text ("" when absent): tests compare the shipped
// YAML with it.
template <typename T>
std::string OptionDefaultText(std::type_identity_t<OptionTable<T>> table, const T& o, const std::string& key) {
  for (const OptionRow<T>& row : table) {
    if (key == row.key) return option_table_internal::ValueText(row, o);
  }
  return "";
}

}  // namespace loci
