// Questions about changes of the map over time ("what changed since 2 hours ago", "what is
// new"), parsed before the spatial grammar (parser.h).
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/status.h"
#include "query/parser.h"
#include "query/vocabulary.h"

namespace loci::query {

// nullopt when `words` (Tokenize) do not ask about changes; else the parsed kChanges query, or
// InvalidArgument for a time that cannot be read.
std::optional<StatusOr<ParsedQuery>> ParseChangeQuestion(const std::vector<std::string>& words,
                                                         std::string_view text,
                                                         const Vocabulary& vocabulary);

// "2026-12-05" (midnight UTC) as ns since the epoch; nullopt when not a date.
std::optional<int64_t> ParseDateNs(const std::string& word);

}  // namespace loci::query
