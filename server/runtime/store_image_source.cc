#include "server/runtime/store_image_source.h"

#include "server/runtime/keyframe_decoder.h"

namespace loci::server {
StatusOr<std::optional<place::KeyframeImages>> StoreImageSource::Read(int64_t keyframe_id) {
  KeyframeScan one;
  one.last_id = keyframe_id;
  std::optional<KeyframeRecord> found;
  LOCI_RETURN_IF_ERROR(store_->ForEachKeyframe(
      keyframe_id - 1,
      [&](KeyframeRecord rec) -> Status {
        found = std::move(rec);
        return absl::OkStatus();
      },
      one));
  if (!found || found->rgb_jpeg.empty() || found->depth_png.empty()) {
    return std::optional<place::KeyframeImages>();
  }
  StatusOr<StoredImages> images = DecodeStoredImages(*found);
  if (!images.ok()) {
    return absl::DataLossError(absl::StrCat("keyframe ", keyframe_id, ": stored images: ",
                                            images.status().message()));
  }
  return std::optional<place::KeyframeImages>(
      place::KeyframeImages{std::move(images->bgr), std::move(images->depth_m), found->camera});
}

}  // namespace loci::server
