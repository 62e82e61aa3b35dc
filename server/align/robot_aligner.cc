#include "server/align/robot_aligner.h"

#include <spdlog/spdlog.h>

#include "common/time.h"
#include "server/place/geometric_verification.h"

namespace loci::server {

RobotAligner::RobotAligner(const place::PlaceOptions& place, const AlignOptions& options,
                           place::FeatureStore* features, place::KeyframeImageSource* images)
    : place_(place),
      options_(options),
      own_features_(features ? nullptr : std::make_unique<place::MemoryFeatureStore>()),
      cache_(features ? features : own_features_.get(),
             static_cast<size_t>(place.features.cache_keyframes)),
      dense_cache_(static_cast<size_t>(place.dense.cache_keyframes)),
      dense_refiner_(place.dense),
      images_(images),
      db_(place.vocabulary, place.query),
      gate_(place.consistency) {}

std::string RobotAligner::Key(int64_t session_row) { return absl::StrCat("s", session_row); }

void RobotAligner::AddSession(int64_t session_row, std::optional<SE3d> T_base_odom) {
  std::lock_guard<std::mutex> lock(sessions_mu_);
  Session s;
  s.T_base_odom = T_base_odom;
  sessions_.try_emplace(session_row, std::move(s));
}

std::optional<SE3d> RobotAligner::Alignment(int64_t session_row) const {
  std::lock_guard<std::mutex> lock(sessions_mu_);
  auto it = sessions_.find(session_row);
  return it == sessions_.end() ? std::nullopt : it->second.T_base_odom;
}

bool RobotAligner::Known(int64_t session_row) const {
  std::lock_guard<std::mutex> lock(sessions_mu_);
  return sessions_.count(session_row) > 0;
}

bool RobotAligner::AnyAligned() const {
  std::lock_guard<std::mutex> lock(sessions_mu_);
  for (const auto& [row, s] : sessions_) {
    if (s.T_base_odom) return true;
  }
  return false;
}

std::pair<int64_t, SE3d> RobotAligner::IslandOfLocked(int64_t session_row) const {
  auto it = sessions_.find(session_row);
  if (it == sessions_.end() || it->second.island_row == 0) return {session_row, SE3d::Identity()};
  return {it->second.island_row, it->second.T_island_odom};
}

std::pair<int64_t, SE3d> RobotAligner::IslandOf(int64_t session_row) const {
  std::lock_guard<std::mutex> lock(sessions_mu_);
  return IslandOfLocked(session_row);
}

bool RobotAligner::SameIsland(int64_t a_row, int64_t b_row) const {
  std::lock_guard<std::mutex> lock(sessions_mu_);
  return IslandOfLocked(a_row).first == IslandOfLocked(b_row).first;
}

void RobotAligner::SetIsland(int64_t session_row, int64_t island_row, const SE3d& T_island_odom) {
  std::lock_guard<std::mutex> lock(sessions_mu_);
  auto it = sessions_.find(session_row);
  if (it == sessions_.end() || it->second.T_base_odom) return;
  it->second.island_row = island_row;
  it->second.T_island_odom = T_island_odom;
}

AlignStats RobotAligner::Stats() const {
  std::lock_guard<std::mutex> lock(stats_mu_);
  AlignStats s = stats_;
  return s;
}

void RobotAligner::SetAlignment(int64_t session_row, const SE3d& T_base_odom) {
  std::lock_guard<std::mutex> lock(sessions_mu_);
  auto it = sessions_.find(session_row);
  if (it != sessions_.end() && it->second.T_base_odom) it->second.T_base_odom = T_base_odom;
}

StatusOr<bool> RobotAligner::CountIn(const AlignKeyframe& kf) {
  std::lock_guard<std::mutex> lock(sessions_mu_);
  auto it = sessions_.find(kf.session_row);
  if (it == sessions_.end()) {
    return absl::FailedPreconditionError(
        absl::StrCat("keyframe ", kf.keyframe_id, ": session ", kf.session_row, " not declared"));
  }
  Session& s = it->second;
  if (s.keyframes++ == 0) s.first_t_ns = kf.t_ns;
  s.last_t_ns = kf.t_ns;
  if (kf.keyframe_id == s.delay_keyframe_id) {
    s.delay = AlignmentDelay{s.keyframes, 1e-9 * static_cast<double>(kf.t_ns - s.first_t_ns)};
    s.delay_keyframe_id = 0;
  }
  if (kf.gravity_cam) {
    it->second.gravity_sum_odom += kf.T_odom_kf.linear() * *kf.gravity_cam;
    ++it->second.gravity_count;
  }
  return it->second.T_base_odom.has_value();
}

void RobotAligner::CountIndexed(double t0_ms) {
  ++stats_.keyframes;
  stats_.place_ms_total += ThreadCpuMs() - t0_ms;
  stats_.vocabulary_words = db_.words();
}

Status RobotAligner::Index(const AlignKeyframe& kf, const place::BowVector& bow) {
  LOCI_RETURN_IF_ERROR(db_.Insert(kf.keyframe_id, Key(kf.session_row), bow));
  indexed_[kf.keyframe_id] = {kf.session_row, kf.t_ns, kf.T_odom_kf};
  return absl::OkStatus();
}

StatusOr<AlignOutcome> RobotAligner::AddKeyframe(const AlignKeyframe& kf, const cv::Mat& bgr,
                                                 const cv::Mat& depth_m,
                                                 const PinholeCamera& camera, bool match) {
  const double t0_ms = ThreadCpuMs();
  std::lock_guard<std::mutex> work(work_mu_);
  if (indexed_.count(kf.keyframe_id)) return AlignOutcome();  // re-indexed
  LOCI_ASSIGN_OR_RETURN(const bool aligned, CountIn(kf));
  LOCI_ASSIGN_OR_RETURN(Described q,
                        Describe(bgr, depth_m, camera, /*add_words=*/true, /*dense=*/match));
  place::KeyframeFeatures& features = q.features;
  const place::BowVector& bow = q.bow;
  const std::shared_ptr<const place::DenseFrame>& dense = q.dense;
  AlignOutcome out;
  std::optional<SessionAlignment>& result = out.alignment;
  if (match && !aligned) {
    // With loops, also its own island's older keyframes: the island's own loop closure.
    out.matches = Match(kf, features, bow,
                        /*loops=*/options_.loops.enabled && options_.loops.island_max_verify > 0,
                        /*query_aligned=*/false, dense.get());
    result = Gate(kf, Estimates(kf, out.matches));
    if (result) {
      out.island_alignments = AlignIsland(*result);
    } else {
      out.join = Join(kf, out.matches);
    }
  } else if (match && options_.loops.enabled) {
    out.matches = Match(kf, features, bow, /*loops=*/true, /*query_aligned=*/true, dense.get());
    out.island_alignments = Pull(kf, out.matches);
  } else if (match && Refining(kf.session_row)) {
    out.matches = Match(kf, features, bow, /*loops=*/false, /*query_aligned=*/true, dense.get());
    result = Refine(kf, Estimates(kf, out.matches));
  }
  if (Status st = cache_.Put(kf.keyframe_id, std::move(features)); !st.ok()) {
    spdlog::warn("keyframe {}: features not stored ({}); it is matched while cached",
                 kf.keyframe_id, st.ToString());
  }
  if (dense) dense_cache_.Put(kf.keyframe_id, dense);
  LOCI_RETURN_IF_ERROR(Index(kf, bow));
  std::lock_guard<std::mutex> lock(stats_mu_);
  CountIndexed(t0_ms);
  if (result) ++(result->refined ? stats_.refinements : stats_.merges_accepted);
  return out;
}

StatusOr<RobotAligner::Described> RobotAligner::Describe(const cv::Mat& bgr,
                                                         const cv::Mat& depth_m,
                                                         const PinholeCamera& camera,
                                                         bool add_words, bool dense) {
  Described out;
  LOCI_ASSIGN_OR_RETURN(out.features,
                        place::ExtractFeatures(bgr, depth_m, camera, place_.features));
  out.bow = db_.Quantise(out.features.descriptors, add_words);
  if (dense && place_.dense.enabled) {
    out.dense = std::make_shared<const place::DenseFrame>(
        place::MakeDenseFrame(bgr, depth_m, camera, place_.dense));
  }
  return out;
}

Status RobotAligner::IndexStored(const AlignKeyframe& kf, place::KeyframeFeatures features) {
  const double t0_ms = ThreadCpuMs();
  std::lock_guard<std::mutex> work(work_mu_);
  if (indexed_.count(kf.keyframe_id)) return absl::OkStatus();
  LOCI_RETURN_IF_ERROR(features.CheckConsistent());
  LOCI_RETURN_IF_ERROR(CountIn(kf).status());
  const place::BowVector bow = db_.Quantise(features.descriptors, /*add_words=*/true);
  cache_.Keep(kf.keyframe_id, std::move(features));
  LOCI_RETURN_IF_ERROR(Index(kf, bow));
  std::lock_guard<std::mutex> lock(stats_mu_);
  CountIndexed(t0_ms);
  ++stats_.indexed_from_store;
  return absl::OkStatus();
}

std::vector<VerifiedMatch> RobotAligner::Match(const AlignKeyframe& kf,
                                               const place::KeyframeFeatures& features,
                                               const place::BowVector& bow, bool loops,
                                               bool query_aligned,
                                               const place::DenseFrame* dense,
                                               bool aligned_only) {
  std::vector<VerifiedMatch> matches;
  // An unaligned query verifies loops.island_max_verify candidates of its own island (its loops)
  // and max_verify of the rest (where it may be aligned or joined), so revisiting its own places
  // does not delay its alignment.
  int tried = 0, tried_own_island = 0, dense_tried = 0;
  uint64_t verified = 0, rejected = 0, missing = 0;
  const uint64_t read_before = cache_.Stats().misses;
  for (const place::PlaceCandidate& c : db_.Query(bow, Key(kf.session_row))) {
    auto a = indexed_.find(c.keyframe_id);
    if (a == indexed_.end()) continue;
    const bool loop = a->second.session_row == kf.session_row;
    if (loop && (!loops || kf.t_ns - a->second.t_ns < options_.loops.min_gap_ns())) continue;
    // A candidate of an unaligned session: for an unaligned query (in its own island only with
    // loops), and for an aligned one with loops (Pull); never for a query ahead (aligned_only).
    const bool own_island = !query_aligned && !Alignment(a->second.session_row) &&
                            SameIsland(a->second.session_row, kf.session_row);
    if (!loop && !Alignment(a->second.session_row) &&
        (aligned_only || (query_aligned && !loops) || (own_island && !loops))) {
      continue;
    }
    int& budget = own_island ? tried_own_island : tried;
    if (budget >= (own_island ? options_.loops.island_max_verify : options_.max_verify)) {
      const bool own_done =
          query_aligned || !loops || tried_own_island >= options_.loops.island_max_verify;
      if (tried >= options_.max_verify && own_done) break;
      continue;
    }
    ++budget;
    StatusOr<std::shared_ptr<const place::KeyframeFeatures>> stored = cache_.Get(c.keyframe_id);
    if (!stored.ok()) {
      spdlog::warn("place recognition: candidate keyframe {} skipped: {}", c.keyframe_id,
                   stored.status().ToString());
      ++missing;
      continue;
    }
    const place::Verification v = place::VerifyPair(**stored, features, place_.verify);
    if (!v.accepted) {
      ++rejected;
      continue;
    }
    // An unaligned robot's own loops are not refined densely (about 25 ms each): its keyframes
    // go through place recognition as fast as they can, so that it is aligned soon.
    const bool refine =
        !own_island && static_cast<int>(++dense_tried) <= place_.dense.max_per_keyframe;
    ++verified;
    spdlog::debug("verified match {}-{}: {} inliers, RMS {:.4f} m, rotation sigma {:.3f} deg, "
                  "chi2/pair {:.2f}, inlier area {:.3f}",
                  c.keyframe_id, kf.keyframe_id, v.inliers, v.rms_m, v.rotation_sigma_deg,
                  v.chi2_per_pair, v.inlier_area);
    const SE3d T_a_b = RefinedDense(c.keyframe_id, refine ? dense : nullptr, v.T_a_b);
    matches.push_back({c.keyframe_id, kf.keyframe_id, T_a_b, v.inliers, v.rms_m, loop});
  }
  std::lock_guard<std::mutex> lock(stats_mu_);
  ++stats_.queries;
  stats_.verified += verified;
  stats_.rejected += rejected;
  stats_.features_missing += missing;
  stats_.features_read += cache_.Stats().misses - read_before;
  return matches;
}

SE3d RobotAligner::RefinedDense(int64_t a_id, const place::DenseFrame* b, const SE3d& T_a_b) {
  if (b == nullptr) return T_a_b;
  const std::shared_ptr<const place::DenseFrame> a = DenseFrameOf(a_id);
  std::optional<SE3d> refined;
  if (a) refined = dense_refiner_.Refine(*a, *b, T_a_b);
  std::lock_guard<std::mutex> lock(stats_mu_);
  ++(!a ? stats_.dense_without_images : refined ? stats_.dense_refined : stats_.dense_refused);
  return refined.value_or(T_a_b);
}

std::shared_ptr<const place::DenseFrame> RobotAligner::DenseFrameOf(int64_t a_id) {
  if (const std::shared_ptr<const place::DenseFrame>* cached = dense_cache_.Get(a_id)) {
    return *cached;
  }
  if (images_ == nullptr) return nullptr;
  StatusOr<std::optional<place::KeyframeImages>> read = images_->Read(a_id);
  if (!read.ok()) {
    spdlog::warn("dense refinement: keyframe {}'s images: {}", a_id, read.status().ToString());
    return nullptr;
  }
  if (!read->has_value()) return nullptr;
  const place::KeyframeImages& im = **read;
  auto frame = std::make_shared<const place::DenseFrame>(
      place::MakeDenseFrame(im.bgr, im.depth_m, im.camera, place_.dense));
  dense_cache_.Put(a_id, frame);
  std::lock_guard<std::mutex> lock(stats_mu_);
  ++stats_.dense_frames_read;
  return frame;
}

void RobotAligner::SetMappedPoses(int64_t map_row,
                                  const std::vector<std::pair<int64_t, SE3d>>& T_map_kf) {
  std::lock_guard<std::mutex> lock(mapped_mu_);
  for (const auto& [id, T] : T_map_kf) mapped_[id] = {map_row, T};
}

SE3d RobotAligner::MappedPose(int64_t a_id, const IndexedKeyframe& a, int64_t map_row,
                              const SE3d& T_map_odom) const {
  {
    std::lock_guard<std::mutex> lock(mapped_mu_);
    auto it = mapped_.find(a_id);
    if (it != mapped_.end() && it->second.map_row == map_row) return it->second.T_map_kf;
  }
  return T_map_odom * a.T_odom_kf;
}

std::vector<SE3d> RobotAligner::Estimates(const AlignKeyframe& kf,
                                          const std::vector<VerifiedMatch>& matches) const {
  std::vector<SE3d> estimates;
  for (const VerifiedMatch& m : matches) {
    if (m.loop) continue;
    const IndexedKeyframe& a = indexed_.at(m.a_id);
    const std::optional<SE3d> T_base_odom_a = Alignment(a.session_row);
    if (!T_base_odom_a) continue;
    estimates.push_back(MappedPose(m.a_id, a, kSharedGraph, *T_base_odom_a) * m.T_a_b *
                        kf.T_odom_kf.inverse());
  }
  return estimates;
}

std::optional<SessionAlignment> RobotAligner::Gate(const AlignKeyframe& kf,
                                                   const std::vector<SE3d>& estimates,
                                                   bool counted) {
  // One estimate per keyframe: the best-ranked verified candidate's (the gate counts keyframes).
  if (estimates.empty()) return std::nullopt;
  const place::ConsistencyGate::Decision d =
      gate_.Add(Key(kf.session_row), kf.keyframe_id, estimates.front());
  if (d.verdict == place::ConsistencyGate::Verdict::kReset) {
    std::lock_guard<std::mutex> lock(stats_mu_);
    ++stats_.merge_resets;
  }
  if (d.verdict != place::ConsistencyGate::Verdict::kAccepted) return std::nullopt;
  SessionAlignment out{kf.session_row, d.T_x_y, kf.keyframe_id, d.agreeing, false, false};
  std::lock_guard<std::mutex> lock(sessions_mu_);
  Session& s = sessions_.at(kf.session_row);
  if (options_.level_with_gravity) out.levelled = Level(s, kf.T_odom_kf.translation(), &out.T_base_odom);
  s.T_base_odom = out.T_base_odom;
  s.recognised = true;
  if (counted) {
    s.delay = AlignmentDelay{s.keyframes, 1e-9 * static_cast<double>(kf.t_ns - s.first_t_ns)};
  } else {
    s.delay_keyframe_id = kf.keyframe_id;  // CountIn sets it when the keyframe comes in order
  }
  s.estimates.assign(static_cast<size_t>(d.agreeing), d.T_x_y);
  s.next_refine = 2 * s.estimates.size();
  if (static_cast<int>(s.next_refine) > options_.refine_max_matches) s.next_refine = 0;
  spdlog::info("session row {} aligned at keyframe {} ({} agreeing matches{})", kf.session_row,
               kf.keyframe_id, d.agreeing, out.levelled ? ", levelled with gravity" : "");
  return out;
}

std::optional<IslandJoin> RobotAligner::Join(const AlignKeyframe& kf,
                                             const std::vector<VerifiedMatch>& matches) {
  std::lock_guard<std::mutex> lock(sessions_mu_);
  const auto [own_island, T_own_odom] = IslandOfLocked(kf.session_row);
  for (const VerifiedMatch& m : matches) {  // the best-ranked match to another island
    const IndexedKeyframe& a = indexed_.at(m.a_id);
    if (m.loop || sessions_.at(a.session_row).T_base_odom) continue;
    const auto [island, T_island_odomA] = IslandOfLocked(a.session_row);
    if (island == own_island) continue;
    const SE3d T_island_odom =
        MappedPose(m.a_id, a, island, T_island_odomA) * m.T_a_b * kf.T_odom_kf.inverse();
    const place::ConsistencyGate::Decision d =
        gate_.Add(absl::StrCat("j", own_island, ">", island), kf.keyframe_id,
                  T_island_odom * T_own_odom.inverse());
    if (d.verdict != place::ConsistencyGate::Verdict::kAccepted) return std::nullopt;
    SE3d T_island_own = d.T_x_y;
    const auto [down_to, n_to] = IslandDown(island);
    const auto [down_from, n_from] = IslandDown(own_island);
    const bool levelled = options_.level_with_gravity && n_to >= options_.min_gravity_keyframes &&
                          n_from >= options_.min_gravity_keyframes;
    if (levelled) {
      T_island_own = LevelOnto(T_island_own, down_from, down_to,
                               T_island_own * (T_own_odom * kf.T_odom_kf.translation()));
    }
    IslandJoin join{own_island, island, {}, kf.keyframe_id};
    for (auto& [row, s] : sessions_) {
      if (s.T_base_odom || IslandOfLocked(row).first != own_island) continue;
      s.T_island_odom = T_island_own * IslandOfLocked(row).second;
      s.island_row = island;
      join.T_island_odom.emplace_back(row, s.T_island_odom);
    }
    spdlog::info("island {} joined island {} at keyframe {} ({} agreeing matches{})", own_island,
                 island, kf.keyframe_id, d.agreeing, levelled ? ", levelled with gravity" : "");
    return join;
  }
  return std::nullopt;
}

std::vector<SessionAlignment> RobotAligner::AlignIsland(const SessionAlignment& aligned) {
  std::lock_guard<std::mutex> lock(sessions_mu_);
  const auto [island, T_island_odom] = IslandOfLocked(aligned.session_row);
  const SE3d T_base_island = aligned.T_base_odom * T_island_odom.inverse();
  std::vector<SessionAlignment> out;
  for (auto& [row, s] : sessions_) {
    if (s.T_base_odom || IslandOfLocked(row).first != island) continue;
    s.T_base_odom = T_base_island * IslandOfLocked(row).second;
    s.recognised = true;
    out.push_back({row, *s.T_base_odom, aligned.keyframe_id, aligned.matches, aligned.levelled,
                   false});
  }
  return out;
}

std::optional<AlignmentDelay> RobotAligner::Delay(int64_t session_row) const {
  std::lock_guard<std::mutex> lock(sessions_mu_);
  auto it = sessions_.find(session_row);
  return it == sessions_.end() ? std::nullopt : it->second.delay;
}

bool RobotAligner::Indexed(int64_t keyframe_id) const {
  std::lock_guard<std::mutex> work(work_mu_);
  return indexed_.count(keyframe_id) > 0;
}

bool RobotAligner::Refining(int64_t session_row) const {
  std::lock_guard<std::mutex> lock(sessions_mu_);
  auto it = sessions_.find(session_row);
  return it != sessions_.end() && it->second.recognised && it->second.next_refine > 0;
}

std::optional<SessionAlignment> RobotAligner::Refine(const AlignKeyframe& kf,
                                                     const std::vector<SE3d>& estimates) {
  if (estimates.empty()) return std::nullopt;
  std::lock_guard<std::mutex> lock(sessions_mu_);
  Session& s = sessions_.at(kf.session_row);
  // The best-ranked verified match, when it agrees with the placement so far.
  if (!gate_.Agree(*s.T_base_odom, estimates.front())) return std::nullopt;
  s.estimates.push_back(estimates.front());
  if (s.estimates.size() < s.next_refine) return std::nullopt;
  SessionAlignment out{kf.session_row, place::MeanTransform(s.estimates), kf.keyframe_id,
                       static_cast<int>(s.estimates.size()), false, true};
  if (options_.level_with_gravity) out.levelled = Level(s, kf.T_odom_kf.translation(), &out.T_base_odom);
  s.T_base_odom = out.T_base_odom;
  s.next_refine *= 2;
  if (static_cast<int>(s.next_refine) > options_.refine_max_matches) s.next_refine = 0;
  spdlog::info("session row {} placement refined from {} matches{}", kf.session_row,
               out.matches, out.levelled ? ", levelled with gravity" : "");
  return out;
}

bool RobotAligner::Level(const Session& session, const Vec3d& pivot_odom,
                         SE3d* T_base_odom) const {
  if (session.gravity_count < options_.min_gravity_keyframes) return false;
  const auto [down_base, count] = BaseDown();
  if (count < options_.min_gravity_keyframes || down_base.norm() < 1e-9) return false;
  *T_base_odom = LevelOnto(*T_base_odom, session.gravity_sum_odom, down_base,
                           *T_base_odom * pivot_odom);
  return true;
}

std::pair<Vec3d, int> RobotAligner::BaseDown() const {
  Vec3d down = Vec3d::Zero();
  int count = 0;
  for (const auto& [row, s] : sessions_) {
    if (!s.T_base_odom || s.gravity_count == 0) continue;
    down += s.T_base_odom->linear() * s.gravity_sum_odom;
    count += s.gravity_count;
  }
  return {down, count};
}

std::pair<Vec3d, int> RobotAligner::IslandDown(int64_t island_row) const {
  Vec3d down = Vec3d::Zero();
  int count = 0;
  for (const auto& [row, s] : sessions_) {
    if (s.T_base_odom || IslandOfLocked(row).first != island_row) continue;
    down += IslandOfLocked(row).second.linear() * s.gravity_sum_odom;
    count += s.gravity_count;
  }
  return {down, count};
}

SE3d LevelOnto(const SE3d& T_to_from, const Vec3d& down_from, const Vec3d& down_to,
               const Vec3d& pivot_to) {
  if (down_from.norm() < 1e-9 || down_to.norm() < 1e-9) return T_to_from;
  const Vec3d down_from_in_to = T_to_from.linear() * down_from.normalized();
  const Eigen::Matrix3d R_fix =
      Quatd::FromTwoVectors(down_from_in_to, down_to.normalized()).toRotationMatrix();
  SE3d levelled = SE3d::Identity();
  levelled.linear() = R_fix * T_to_from.linear();
  // The pivot (where the images put the matched keyframe) stays where it is.
  levelled.translation() = pivot_to - R_fix * (pivot_to - T_to_from.translation());
  return levelled;
}

}  // namespace loci::server
