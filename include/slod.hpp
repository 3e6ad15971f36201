/* slod.hpp: a thin, header-only C++17 RAII wrapper over slod.h.
 *
 * Written by hand (slod.h is generated); it adds no functionality, only ownership and errors:
 *
 * - Errors are exceptions: every failing call throws slod::Error, which carries the SlodResult
 *   code (code()) and a message naming the call, the code and slod_last_error()'s detail.
 *   Destructors never throw (they ignore the result of the destroy call).
 * - Ownership: World owns a SlodWorld; Cloth, Rig and Crowd each own one object inside a world
 *   and destroy it in their destructor. They are move-only. Each handle shares ownership of its
 *   world, so the SlodWorld is destroyed when the World and the last handle made in it are all
 *   gone, in whatever order that happens (moving a World anywhere, or destroying it before its
 *   handles, is safe). Characters are plain SlodCharacterId values owned by their Crowd:
 *   Crowd::remove destroys one, the Crowd's destructor all.
 * - A Rig may be destroyed while Crowds made from it live on (they keep the rig's data).
 * - Buffers: the vector-returning queries size the buffer with a first call, then copy.
 * - Threads: as slod.h: one thread at a time per World, and a World with its handles counts as
 *   one (they share it); const methods only read.
 */
#ifndef SLOD_HPP
#define SLOD_HPP

#include "slod.h"

#include <array>
#include <cstddef>
#include <memory>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace slod {

/// A float[3] as the C API stores it.
using Vec3 = std::array<float, 3>;
/// A float[16] column-major matrix as the C API stores it.
using Mat4 = std::array<float, 16>;
static_assert(sizeof(Vec3) == 3 * sizeof(float), "std::array<float, 3> must be a float[3]");
static_assert(sizeof(Mat4) == 16 * sizeof(float), "std::array<float, 16> must be a float[16]");

/// A failed slod call: the result code and the thread's last error detail.
class Error : public std::runtime_error {
public:
    Error(SlodResult code, const std::string &message) : std::runtime_error(message), code_(code) {}
    /// The SlodResult code of the failed call.
    SlodResult code() const noexcept { return code_; }

private:
    SlodResult code_;
};

/// The calling thread's last error detail (empty after a success).
inline std::string last_error() {
    size_t len = 0;
    slod_last_error(nullptr, 0, &len);
    std::string s(len + 1, '\0');
    slod_last_error(&s[0], s.size(), &len);
    s.resize(len < s.size() ? len : s.size() - 1);
    return s;
}

/// Throws slod::Error unless `r` is SLOD_RESULT_OK. The message is the call's name and the
/// thread's last error detail (which already names the code's meaning), or the code's generic
/// text when there is no detail.
inline void check(SlodResult r, const char *call) {
    if (r != SLOD_RESULT_OK) {
        std::string detail = last_error();
        throw Error(r, std::string(call) + ": " + (detail.empty() ? slod_result_str(r) : detail));
    }
}

namespace detail {
/// Shared ownership of a SlodWorld: the World and every handle made in it hold one.
using WorldRef = std::shared_ptr<SlodWorld>;

/// Copy-out with sizing: `f(out, cap, &len)` is called with cap 0, then with the needed count.
template <class T, class C, class F> std::vector<T> fetch(F f, const char *call) {
    size_t n = 0;
    check(f(nullptr, 0, &n), call); // sizing succeeds and writes the count
    if (n == 0) return {};
    std::vector<T> v(n);
    check(f(reinterpret_cast<C *>(v.data()), n, &n), call);
    v.resize(n);
    return v;
}
} // namespace detail

/// Owns a SlodWorld: everything else lives in one.
class World {
public:
    explicit World(const SlodWorldDesc &desc = slod_default_world_desc()) {
        SlodWorld *w = nullptr;
        check(slod_world_create(&desc, &w), "slod_world_create");
        try {
            world_ = detail::WorldRef(w, [](SlodWorld *p) { slod_world_destroy(p); });
        } catch (...) {
            slod_world_destroy(w);
            throw;
        }
    }
    World(World &&o) noexcept = default;
    World &operator=(World &&o) noexcept = default;
    World(const World &) = delete;
    World &operator=(const World &) = delete;
    ~World() = default;

    /// The C handle (NULL after a move; destroyed with the last owner).
    SlodWorld *get() const noexcept { return world_.get(); }
    /// Shared ownership of the C handle, as the handles made in this world keep it.
    const detail::WorldRef &share() const noexcept { return world_; }

    void set_camera(const SlodCamera &camera) {
        check(slod_world_set_camera(world_.get(), &camera), "slod_world_set_camera");
    }
    void set_light(const SlodLight &light) {
        check(slod_world_set_light(world_.get(), &light), "slod_world_set_light");
    }
    SlodWorldCounts counts() const {
        SlodWorldCounts c;
        check(slod_world_counts(world_.get(), &c), "slod_world_counts");
        return c;
    }
    /// Sets the world's frame budget (slod_world_set_budget).
    void set_budget(const SlodWorldBudgetDesc &desc) {
        check(slod_world_set_budget(world_.get(), &desc), "slod_world_set_budget");
    }
    /// Advances every crowd and cloth by one frame under the budget (slod_world_step).
    SlodWorldStepStats step(float dt) {
        SlodWorldStepStats s;
        check(slod_world_step(world_.get(), dt, &s), "slod_world_step");
        return s;
    }
    /// How a cloth takes part in the budget (slod_world_set_cloth_share).
    void set_share(SlodClothId cloth, SlodBudgetShare share, float weight = 1.0f) {
        check(slod_world_set_cloth_share(world_.get(), cloth, static_cast<uint32_t>(share), weight),
              "slod_world_set_cloth_share");
    }
    /// How a crowd takes part in the budget (slod_world_set_crowd_share).
    void set_share(SlodCrowdId crowd, SlodBudgetShare share, float weight = 1.0f) {
        check(slod_world_set_crowd_share(world_.get(), crowd, static_cast<uint32_t>(share), weight),
              "slod_world_set_crowd_share");
    }
    /// The budget's shared on-screen error bound now, px (slod_world_error_bound).
    float error_bound() const {
        float px = 0.0f;
        check(slod_world_error_bound(world_.get(), &px), "slod_world_error_bound");
        return px;
    }

private:
    detail::WorldRef world_;
};

/// Owns one cloth of a world.
class Cloth {
public:
    /// A grid cloth (slod_cloth_create_grid).
    static Cloth grid(World &world, const SlodClothDesc &desc = slod_default_cloth_desc()) {
        SlodClothId id;
        check(slod_cloth_create_grid(world.get(), &desc, &id), "slod_cloth_create_grid");
        return Cloth(world.share(), id);
    }
    /// A cloth from the host's mesh (slod_cloth_create_mesh); `masses` empty for area-lumped.
    static Cloth mesh(World &world, const SlodClothDesc &desc, const std::vector<Vec3> &positions,
                      const std::vector<std::array<uint32_t, 3>> &triangles,
                      const std::vector<float> &masses = {}) {
        SlodClothId id;
        check(slod_cloth_create_mesh(
                  world.get(), &desc, positions.empty() ? nullptr : positions[0].data(),
                  positions.size(), triangles.empty() ? nullptr : triangles[0].data(),
                  triangles.size(), masses.empty() ? nullptr : masses.data(), &id),
              "slod_cloth_create_mesh");
        return Cloth(world.share(), id);
    }
    Cloth(Cloth &&o) noexcept : world_(std::move(o.world_)), id_(std::exchange(o.id_, SlodClothId{0, 0})) {}
    Cloth &operator=(Cloth &&o) noexcept {
        if (this != &o) {
            reset();
            world_ = std::move(o.world_);
            id_ = std::exchange(o.id_, SlodClothId{0, 0});
        }
        return *this;
    }
    Cloth(const Cloth &) = delete;
    Cloth &operator=(const Cloth &) = delete;
    ~Cloth() { reset(); }

    /// The C id (owned by this object).
    SlodClothId id() const noexcept { return id_; }
    /// Destroys the cloth now (no effect if already done).
    void reset() noexcept {
        if (id_.index1 != 0) (void)slod_cloth_destroy(world_.get(), id_);
        id_ = SlodClothId{0, 0};
    }

    void step() { check(slod_cloth_step(world_.get(), id_), "slod_cloth_step"); }
    /// Runs the next step's due evaluation now (see `slod_cloth_evaluate_ahead`); whether one ran.
    bool evaluate_ahead() {
        bool ran = false;
        check(slod_cloth_evaluate_ahead(world_.get(), id_, &ran), "slod_cloth_evaluate_ahead");
        return ran;
    }
    /// Measures part of the next step's due evaluation now, up to `fraction` of its nodes (see
    /// `slod_cloth_evaluate_ahead_part`); whether a part ran.
    bool evaluate_ahead_part(float fraction) {
        bool ran = false;
        check(slod_cloth_evaluate_ahead_part(world_.get(), id_, fraction, &ran),
              "slod_cloth_evaluate_ahead_part");
        return ran;
    }
    void refine(uint32_t node) { check(slod_cloth_refine(world_.get(), id_, node), "slod_cloth_refine"); }
    void coarse(uint32_t node) { check(slod_cloth_coarse(world_.get(), id_, node), "slod_cloth_coarse"); }
    void pin(uint32_t vertex, const Vec3 &at) {
        check(slod_cloth_pin_vertex(world_.get(), id_, vertex, at[0], at[1], at[2]),
              "slod_cloth_pin_vertex");
    }
    void unpin(uint32_t vertex) {
        check(slod_cloth_unpin_vertex(world_.get(), id_, vertex), "slod_cloth_unpin_vertex");
    }
    void set_feedback(const SlodFeedbackDesc &desc) {
        check(slod_cloth_set_feedback(world_.get(), id_, &desc), "slod_cloth_set_feedback");
    }
    void disable_feedback() {
        check(slod_cloth_disable_feedback(world_.get(), id_), "slod_cloth_disable_feedback");
    }

    SlodClothStats stats() const {
        SlodClothStats s;
        check(slod_cloth_stats(world_.get(), id_, &s), "slod_cloth_stats");
        return s;
    }
    size_t node_count() const { return count(slod_cloth_node_count, "slod_cloth_node_count"); }
    size_t link_count() const { return count(slod_cloth_link_count, "slod_cloth_link_count"); }
    size_t interpolations() const {
        return count(slod_cloth_interpolations, "slod_cloth_interpolations");
    }
    size_t vertex_count() const {
        return count(slod_cloth_vertex_count, "slod_cloth_vertex_count");
    }
    SlodNodeInfo node_info(uint32_t node) const {
        SlodNodeInfo info;
        check(slod_cloth_node_info(world_.get(), id_, node, &info), "slod_cloth_node_info");
        return info;
    }
    std::vector<Vec3> node_positions() const {
        return detail::fetch<Vec3, float>(
            [&](float *o, size_t c, size_t *n) {
                return slod_cloth_node_positions(world_.get(), id_, o, c, n);
            },
            "slod_cloth_node_positions");
    }
    std::vector<uint32_t> node_ids() const {
        return detail::fetch<uint32_t, uint32_t>(
            [&](uint32_t *o, size_t c, size_t *n) {
                return slod_cloth_node_ids(world_.get(), id_, o, c, n);
            },
            "slod_cloth_node_ids");
    }
    std::vector<uint32_t> active_nodes() const {
        return detail::fetch<uint32_t, uint32_t>(
            [&](uint32_t *o, size_t c, size_t *n) {
                return slod_cloth_active_nodes(world_.get(), id_, o, c, n);
            },
            "slod_cloth_active_nodes");
    }
    /// Reconstructed finest-level vertex positions (what a renderer draws). A query: reading
    /// never changes the simulation.
    std::vector<Vec3> vertex_positions() const {
        std::vector<Vec3> v(vertex_count());
        size_t n = 0;
        check(slod_cloth_vertex_positions(world_.get(), id_, v.empty() ? nullptr : v[0].data(),
                                          v.size(), &n),
              "slod_cloth_vertex_positions");
        v.resize(n);
        return v;
    }
    std::vector<SlodDebugLink> links() const {
        return detail::fetch<SlodDebugLink, SlodDebugLink>(
            [&](SlodDebugLink *o, size_t c, size_t *n) {
                return slod_cloth_links(world_.get(), id_, o, c, n);
            },
            "slod_cloth_links");
    }

private:
    Cloth(detail::WorldRef world, SlodClothId id) : world_(std::move(world)), id_(id) {}
    size_t count(SlodResult (*f)(const SlodWorld *, SlodClothId, size_t *), const char *call) const {
        size_t n = 0;
        check(f(world_.get(), id_, &n), call);
        return n;
    }

    detail::WorldRef world_;
    SlodClothId id_;
};

/// Owns the world's reference to a rig loaded from glTF.
class Rig {
public:
    static Rig from_file(World &world, const std::string &path) {
        SlodRigId id;
        check(slod_rig_load_file(world.get(), path.c_str(), &id), "slod_rig_load_file");
        return Rig(world.share(), id);
    }
    static Rig from_memory(World &world, const void *bytes, size_t len) {
        SlodRigId id;
        check(slod_rig_load_memory(world.get(), static_cast<const uint8_t *>(bytes), len, &id),
              "slod_rig_load_memory");
        return Rig(world.share(), id);
    }
    Rig(Rig &&o) noexcept : world_(std::move(o.world_)), id_(std::exchange(o.id_, SlodRigId{0, 0})) {}
    Rig &operator=(Rig &&o) noexcept {
        if (this != &o) {
            reset();
            world_ = std::move(o.world_);
            id_ = std::exchange(o.id_, SlodRigId{0, 0});
        }
        return *this;
    }
    Rig(const Rig &) = delete;
    Rig &operator=(const Rig &) = delete;
    ~Rig() { reset(); }

    SlodRigId id() const noexcept { return id_; }
    void reset() noexcept {
        if (id_.index1 != 0) (void)slod_rig_destroy(world_.get(), id_);
        id_ = SlodRigId{0, 0};
    }

    SlodRigInfo info() const {
        SlodRigInfo i;
        check(slod_rig_info(world_.get(), id_, &i), "slod_rig_info");
        return i;
    }
    std::string clip_name(uint32_t clip) const {
        std::vector<char> s = detail::fetch<char, char>(
            [&](char *o, size_t c, size_t *n) {
                return slod_rig_clip_name(world_.get(), id_, clip, o, c, n);
            },
            "slod_rig_clip_name");
        return s.empty() ? std::string() : std::string(s.data());
    }
    float clip_duration(uint32_t clip) const {
        float d = 0.0f;
        check(slod_rig_clip_duration(world_.get(), id_, clip, &d), "slod_rig_clip_duration");
        return d;
    }
    /// The first clip with this name, if any.
    std::optional<uint32_t> find_clip(const std::string &name) const {
        uint32_t c = 0;
        SlodResult r = slod_rig_find_clip(world_.get(), id_, name.c_str(), &c);
        if (r == SLOD_RESULT_INVALID_ARGUMENT) return std::nullopt;
        check(r, "slod_rig_find_clip");
        return c;
    }
    size_t skin_joint_count(uint32_t skin) const {
        size_t n = 0;
        check(slod_rig_skin_joint_count(world_.get(), id_, skin, &n), "slod_rig_skin_joint_count");
        return n;
    }

private:
    Rig(detail::WorldRef world, SlodRigId id) : world_(std::move(world)), id_(id) {}
    detail::WorldRef world_;
    SlodRigId id_;
};

/// Owns a crowd and, through it, its characters.
class Crowd {
public:
    Crowd(World &world, const Rig &rig, const SlodCrowdDesc &desc = slod_default_crowd_desc())
        : world_(world.share()) {
        check(slod_crowd_create(world_.get(), rig.id(), &desc, &id_), "slod_crowd_create");
    }
    Crowd(Crowd &&o) noexcept : world_(std::move(o.world_)), id_(std::exchange(o.id_, SlodCrowdId{0, 0})) {}
    Crowd &operator=(Crowd &&o) noexcept {
        if (this != &o) {
            reset();
            world_ = std::move(o.world_);
            id_ = std::exchange(o.id_, SlodCrowdId{0, 0});
        }
        return *this;
    }
    Crowd(const Crowd &) = delete;
    Crowd &operator=(const Crowd &) = delete;
    ~Crowd() { reset(); }

    SlodCrowdId id() const noexcept { return id_; }
    /// Destroys the crowd and its characters now (no effect if already done).
    void reset() noexcept {
        if (id_.index1 != 0) (void)slod_crowd_destroy(world_.get(), id_);
        id_ = SlodCrowdId{0, 0};
    }

    SlodCharacterId add(const SlodCharacterDesc &desc) {
        SlodCharacterId c;
        check(slod_character_create(world_.get(), id_, &desc, &c), "slod_character_create");
        return c;
    }
    void remove(SlodCharacterId c) {
        check(slod_character_destroy(world_.get(), c), "slod_character_destroy");
    }
    void set_position(SlodCharacterId c, const Vec3 &p) {
        check(slod_character_set_position(world_.get(), c, p[0], p[1], p[2]),
              "slod_character_set_position");
    }
    void set_clip(SlodCharacterId c, uint32_t clip, float time = 0.0f) {
        check(slod_character_set_clip(world_.get(), c, clip, time), "slod_character_set_clip");
    }
    void set_speed(SlodCharacterId c, float speed) {
        check(slod_character_set_speed(world_.get(), c, speed), "slod_character_set_speed");
    }
    void set_lod(const SlodLodDesc &lod) {
        check(slod_crowd_set_lod(world_.get(), id_, &lod), "slod_crowd_set_lod");
    }
    SlodCrowdStats advance(float dt) {
        SlodCrowdStats s;
        check(slod_crowd_advance(world_.get(), id_, dt, &s), "slod_crowd_advance");
        return s;
    }
    size_t size() const {
        size_t n = 0;
        check(slod_crowd_character_count(world_.get(), id_, &n), "slod_crowd_character_count");
        return n;
    }
    /// Bone matrices in skeleton model space, column-major.
    std::vector<Mat4> model_matrices(SlodCharacterId c) const {
        return detail::fetch<Mat4, float>(
            [&](float *o, size_t cap, size_t *n) {
                return slod_character_model_matrices(world_.get(), c, o, cap, n);
            },
            "slod_character_model_matrices");
    }
    /// Skinning matrices of skin `skin` (model × inverse bind), column-major.
    std::vector<Mat4> skinning_matrices(SlodCharacterId c, uint32_t skin) const {
        return detail::fetch<Mat4, float>(
            [&](float *o, size_t cap, size_t *n) {
                return slod_character_skinning_matrices(world_.get(), c, skin, o, cap, n);
            },
            "slod_character_skinning_matrices");
    }

private:
    detail::WorldRef world_;
    SlodCrowdId id_{0, 0};
};

} // namespace slod

#endif /* SLOD_HPP */
