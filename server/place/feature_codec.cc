#include "server/place/feature_codec.h"

#include <bit>
#include <cmath>
#include <cstring>

namespace loci::place {
namespace {

static_assert(std::endian::native == std::endian::little, "the feature codec is little-endian");

constexpr char kMagic[4] = {'L', 'P', 'F', '1'};

template <typename T>
void Put(std::string* out, const T& value) {
  out->append(reinterpret_cast<const char*>(&value), sizeof(T));
}

// Reads consecutive values from a byte span whose length the caller has checked.
class Reader {
 public:
  explicit Reader(std::string_view bytes) : p_(bytes.data()) {}
  template <typename T>
  T Get() {
    T value;
    std::memcpy(&value, p_, sizeof(T));
    p_ += sizeof(T);
    return value;
  }
  const char* Take(size_t n) {
    const char* at = p_;
    p_ += n;
    return at;
  }

 private:
  const char* p_;
};

bool Finite(float a, float b, float c = 0) {
  return std::isfinite(a) && std::isfinite(b) && std::isfinite(c);
}

}  // namespace

StatusOr<std::string> EncodeFeatures(const KeyframeFeatures& f) {
  LOCI_RETURN_IF_ERROR(f.CheckConsistent());
  if (f.size() > kMaxStoredFeatures) return absl::InvalidArgumentError("features: too many");
  std::string out;
  out.reserve(kFeatureHeaderBytes + kFeatureRecordBytes * f.size());
  out.append(kMagic, sizeof(kMagic));
  Put(&out, static_cast<uint32_t>(f.size()));
  for (const double v : {f.camera.fx, f.camera.fy, f.camera.cx, f.camera.cy}) Put(&out, v);
  Put(&out, static_cast<int32_t>(f.camera.width_px));
  Put(&out, static_cast<int32_t>(f.camera.height_px));
  Put(&out, f.level_scale);
  for (size_t i = 0; i < f.size(); ++i) {
    Put(&out, f.uv_px[i].x());
    Put(&out, f.uv_px[i].y());
    Put(&out, f.octave[i]);
    out.append(reinterpret_cast<const char*>(f.descriptors.ptr<uint8_t>(static_cast<int>(i))),
               kDescriptorBytes);
    for (int k = 0; k < 3; ++k) Put(&out, f.p_kf_m[i][k]);
  }
  return out;
}

StatusOr<KeyframeFeatures> DecodeFeatures(std::string_view bytes) {
  auto bad = [](const char* what) {
    return absl::InvalidArgumentError(absl::StrCat("stored features: ", what));
  };
  if (bytes.size() < kFeatureHeaderBytes || std::memcmp(bytes.data(), kMagic, 4) != 0) {
    return bad("not an LPF1 record");
  }
  Reader r(bytes.substr(4));
  const uint32_t count = r.Get<uint32_t>();
  if (count > kMaxStoredFeatures) return bad("count out of range");
  if (bytes.size() != kFeatureHeaderBytes + kFeatureRecordBytes * count) {
    return bad("length does not match the count");
  }
  KeyframeFeatures f;
  f.camera.fx = r.Get<double>();
  f.camera.fy = r.Get<double>();
  f.camera.cx = r.Get<double>();
  f.camera.cy = r.Get<double>();
  f.camera.width_px = r.Get<int32_t>();
  f.camera.height_px = r.Get<int32_t>();
  f.level_scale = r.Get<float>();
  LOCI_RETURN_IF_ERROR(f.camera.Validate());
  if (!(f.level_scale >= 1.0f && f.level_scale <= 4.0f)) return bad("level_scale out of range");
  f.uv_px.resize(count);
  f.octave.resize(count);
  f.p_kf_m.resize(count);
  f.descriptors.create(static_cast<int>(count), kDescriptorBytes, CV_8UC1);
  for (uint32_t i = 0; i < count; ++i) {
    const float u = r.Get<float>(), v = r.Get<float>();
    f.octave[i] = r.Get<uint8_t>();
    std::memcpy(f.descriptors.ptr<uint8_t>(static_cast<int>(i)), r.Take(kDescriptorBytes),
                kDescriptorBytes);
    const float x = r.Get<float>(), y = r.Get<float>(), z = r.Get<float>();
    if (!Finite(u, v) || !Finite(x, y, z) || z < 0) return bad("non-finite or negative value");
    f.uv_px[i] = {u, v};
    f.p_kf_m[i] = {x, y, z};
  }
  return f;
}

}  // namespace loci::place
