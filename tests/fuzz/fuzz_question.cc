// libFuzzer target: the query engine (parser, relation search, answer text) on arbitrary
// question bytes over a synthetic office of 200 objects.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string_view>

#include "query/query_engine.h"
#include "query/synthetic_map.h"

namespace {

struct Fixture {
  loci::query::QueryEngine engine;
  std::shared_ptr<const loci::query::MapIndex> index;
  Fixture() {
    loci::query::SyntheticMapOptions o;
    o.object_count = 200;
    index = engine.Index(loci::query::MapObjectsFromGroundTruth(loci::query::MakeSyntheticOffice(o)),
                         std::nullopt, {});
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static Fixture* f = new Fixture();
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  (void)f->engine.Ask(text, *f->index, {});
  return 0;
}
