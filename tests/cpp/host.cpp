// A C++17 engine-like host: includes slod.h through the RAII wrapper slod.hpp, links the static
// library, drives a cloth and a crowd, and checks what comes back. Exit code 0 = every check
// passed; each failure prints what and where. Built and run by tests/tests/cpp_host.rs.
//
// Usage: host <rig.glb>
#include "slod.h"
#include "slod.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace {

int failures = 0;

#define EXPECT(cond)                                                                           \
    do {                                                                                       \
        if (!(cond)) {                                                                         \
            std::fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond);       \
            ++failures;                                                                        \
        }                                                                                      \
    } while (0)

// Runs `f`, which must throw slod::Error with `code`.
template <class F> void expect_error(F f, SlodResult code, const char *what, int line) {
    try {
        f();
        std::fprintf(stderr, "line %d: %s did not throw\n", line, what);
        ++failures;
    } catch (const slod::Error &e) {
        if (e.code() != code) {
            std::fprintf(stderr, "line %d: %s threw code %u, expected %u: %s\n", line, what,
                         static_cast<unsigned>(e.code()), static_cast<unsigned>(code), e.what());
            ++failures;
        }
    }
}
#define EXPECT_ERROR(expr, code) expect_error([&] { expr; }, code, #expr, __LINE__)

bool finite(const slod::Vec3 &v) {
    return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

SlodCamera camera_at(float z) {
    SlodCamera c{};
    c.position[1] = 0.5f;
    c.position[2] = z;
    c.forward[2] = -1.0f;
    c.up[1] = 1.0f;
    c.fov_y_radians = 1.0f;
    c.viewport_width = 1920;
    c.viewport_height = 1080;
    c.near_plane = 0.05f;
    return c;
}

/// The world step under one budget, through the RAII wrapper: a cost-unit budget moves the
/// shared bound, a cloth forced to full detail reaches its finest cut, bad input is refused
/// and changes nothing.
void budget_checks(slod::World &world) {
    SlodClothDesc desc = slod_default_cloth_desc();
    desc.columns = 17;
    desc.rows = 17;
    desc.initial_level = 2;
    desc.center[2] = -2.0f;
    slod::Cloth near = slod::Cloth::grid(world, desc);
    desc.center[2] = -12.0f;
    slod::Cloth far = slod::Cloth::grid(world, desc);
    world.set_camera(camera_at(2.0f));
    SlodWorldStepStats s = world.step(1.0f / 60.0f);
    EXPECT(s.frame >= 1 && s.cloths == 2 && s.cloth_steps == 2 && s.cost_units > 0.0);
    SlodWorldBudgetDesc b = slod_default_world_budget_desc();
    b.target_kind = SLOD_WORLD_BUDGET_KIND_COST_UNITS;
    b.target_units = 3.0 * s.cost_units;
    world.set_budget(b);
    world.set_share(near.id(), SLOD_BUDGET_SHARE_FULL_DETAIL);
    world.set_share(far.id(), SLOD_BUDGET_SHARE_SHARED, 0.5f);
    SlodWorldBudgetDesc bad = b;
    bad.target_units = std::nan("");
    EXPECT_ERROR(world.set_budget(bad), SLOD_RESULT_INVALID_ARGUMENT);
    bad = b;
    bad.target_kind = 99;
    EXPECT_ERROR(world.set_budget(bad), SLOD_RESULT_INVALID_ARGUMENT);
    EXPECT_ERROR(world.set_share(far.id(), SLOD_BUDGET_SHARE_SHARED, 0.0f),
                 SLOD_RESULT_INVALID_ARGUMENT);
    EXPECT_ERROR(world.step(std::nanf("")), SLOD_RESULT_INVALID_ARGUMENT);
    for (int f = 0; f < 120; ++f) s = world.step(1.0f / 60.0f);
    size_t nodes = 0, full = 0;
    EXPECT(slod_cloth_node_count(world.get(), near.id(), &nodes) == SLOD_RESULT_OK);
    EXPECT(slod_cloth_vertex_count(world.get(), near.id(), &full) == SLOD_RESULT_OK);
    EXPECT(nodes == full);
    EXPECT(world.error_bound() > 0.0f && s.error_bound_px > 0.0f);
}

void cloth_checks(slod::World &world) {
    SlodClothDesc desc = slod_default_cloth_desc();
    desc.columns = 17;
    desc.rows = 17;
    desc.spacing = 1.0f / 16.0f;
    desc.initial_level = 0;
    slod::Cloth cloth = slod::Cloth::grid(world, desc);
    EXPECT(cloth.vertex_count() == 17u * 17u);
    EXPECT(cloth.node_count() == 17u * 17u);
    const float h = 0.5f;
    cloth.pin(0, {-h, 0.0f, -h});
    cloth.pin(16, {h, 0.0f, -h});

    // The world always has a view (the default until the host sets a camera).
    SlodFeedbackDesc fb = slod_default_feedback_desc();
    fb.budget_kind = SLOD_CLOTH_BUDGET_NODES;
    fb.budget_value = 120.0;
    fb.interval = 2;
    world.set_camera(camera_at(2.0f));
    SlodFeedbackDesc bad = fb;
    bad.budget_kind = 7;
    EXPECT_ERROR(cloth.set_feedback(bad), SLOD_RESULT_INVALID_ARGUMENT);
    EXPECT(slod::last_error().find("budget_kind") != std::string::npos);
    bad = fb;
    bad.overlap_step = 2; // 0 or 1: an evaluation beside its step's solver
    EXPECT_ERROR(cloth.set_feedback(bad), SLOD_RESULT_INVALID_ARGUMENT);
    EXPECT(slod::last_error().find("overlap_step") != std::string::npos);
    cloth.set_feedback(fb);

    // Every other step's evaluation runs ahead of it (as a 120 Hz host would, between steps):
    // it still counts once per interval, and a second call before the step runs nothing.
    int ahead = 0;
    for (int s = 0; s < 120; ++s) {
        if (s % 4 == 2) {
            // A node budget's measurement is not split in parts (only an error bound's is).
            EXPECT(!cloth.evaluate_ahead_part(0.5f));
            ahead += cloth.evaluate_ahead();
            EXPECT(!cloth.evaluate_ahead());
        }
        cloth.step();
    }
    EXPECT(ahead == 30);
    SlodClothStats st = cloth.stats();
    EXPECT(st.steps == 120);
    EXPECT(st.evaluations == 60);
    EXPECT(st.coarses > 0);
    // The cut spends at most the node budget (plus the children of coarses still blending).
    EXPECT(cloth.node_count() <= 120u + 4u * cloth.interpolations());
    EXPECT(cloth.node_count() < 17u * 17u);
    std::vector<slod::Vec3> verts = cloth.vertex_positions();
    EXPECT(verts.size() == 17u * 17u);
    float lowest = 0.0f;
    for (const auto &v : verts) {
        EXPECT(finite(v));
        lowest = std::fmin(lowest, v[1]);
    }
    EXPECT(lowest < -0.05f); // hanging from two corners, it falls and swings
    // Pinned vertices stay where they were pinned.
    EXPECT(std::fabs(verts[0][0] + h) < 1e-3f && std::fabs(verts[0][1]) < 1e-3f);
    std::vector<slod::Vec3> nodes = cloth.node_positions();
    std::vector<uint32_t> ids = cloth.node_ids();
    EXPECT(nodes.size() == cloth.node_count() && ids.size() == nodes.size());
    std::vector<SlodDebugLink> links = cloth.links();
    EXPECT(links.size() == cloth.link_count());
    for (const auto &l : links) EXPECT(l.weight >= 0.0f && l.weight <= 1.0f);

    // Explicit refine of a node on the cut; refining it again is refused (locked / off the cut).
    cloth.disable_feedback();
    std::vector<uint32_t> active = cloth.active_nodes();
    uint32_t target = UINT32_MAX;
    for (uint32_t n : active) {
        SlodNodeInfo info = cloth.node_info(n);
        EXPECT(info.on_cut == 1);
        if (info.child_count > 0 && !info.locked) {
            target = n;
            break;
        }
    }
    EXPECT(target != UINT32_MAX);
    if (target != UINT32_MAX) {
        size_t before = cloth.node_count();
        SlodNodeInfo info = cloth.node_info(target);
        cloth.refine(target);
        EXPECT(cloth.node_count() == before - 1 + info.child_count);
        EXPECT(cloth.interpolations() >= 1);
        EXPECT_ERROR(cloth.refine(target), SLOD_RESULT_REFUSED);
        for (int s = 0; s < 10; ++s) cloth.step();
        EXPECT(cloth.node_info(target).on_cut == 0);
    }
    EXPECT_ERROR(cloth.refine(1u << 30), SLOD_RESULT_INVALID_ARGUMENT);
    EXPECT(slod::last_error().find("node") != std::string::npos);
    EXPECT_ERROR(cloth.pin(0, {NAN, 0.0f, 0.0f}), SLOD_RESULT_INVALID_ARGUMENT);

    // A mesh cloth from the host's own triangles: a 4x4 vertex patch.
    std::vector<slod::Vec3> pos;
    std::vector<std::array<uint32_t, 3>> tris;
    for (uint32_t j = 0; j < 4; ++j)
        for (uint32_t i = 0; i < 4; ++i) pos.push_back({0.1f * i, 1.0f, 0.1f * j});
    for (uint32_t j = 0; j < 3; ++j)
        for (uint32_t i = 0; i < 3; ++i) {
            uint32_t a = j * 4 + i;
            tris.push_back({a, a + 1, a + 5});
            tris.push_back({a, a + 5, a + 4});
        }
    slod::Cloth patch = slod::Cloth::mesh(world, slod_default_cloth_desc(), pos, tris);
    EXPECT(patch.vertex_count() == 16);
    patch.step();
    for (const auto &v : patch.vertex_positions()) EXPECT(finite(v) && v[1] < 1.0f);
    tris[0][2] = 99; // an index out of range is refused, naming the argument
    EXPECT_ERROR(slod::Cloth::mesh(world, slod_default_cloth_desc(), pos, tris),
                 SLOD_RESULT_INVALID_ARGUMENT);
    EXPECT(slod::last_error().find("triangles") != std::string::npos);

    // Destroy, then use: the id is stale.
    SlodClothId old = patch.id();
    patch.reset();
    size_t n = 0;
    EXPECT(slod_cloth_node_count(world.get(), old, &n) == SLOD_RESULT_STALE_ID);
}

std::vector<unsigned char> read_file(const char *path) {
    std::ifstream f(path, std::ios::binary);
    return std::vector<unsigned char>(std::istreambuf_iterator<char>(f), {});
}

void crowd_checks(slod::World &world, const char *rig_path) {
    slod::Rig rig = slod::Rig::from_file(world, rig_path);
    std::vector<unsigned char> bytes = read_file(rig_path);
    EXPECT(!bytes.empty());
    slod::Rig same = slod::Rig::from_memory(world, bytes.data(), bytes.size());
    SlodRigInfo info = rig.info(), info2 = same.info();
    EXPECT(info.bones > 0 && info.clips > 0 && info.skins > 0);
    EXPECT(info.bones == info2.bones && info.clips == info2.clips);
    EXPECT(rig.clip_name(0) == same.clip_name(0));
    EXPECT(rig.clip_duration(0) > 0.0f);
    EXPECT(rig.find_clip(rig.clip_name(0)) == std::optional<uint32_t>(0));
    EXPECT(!rig.find_clip("no such clip").has_value());
    EXPECT_ERROR(slod::Rig::from_file(world, "/nonexistent/rig.glb"), SLOD_RESULT_IO_ERROR);
    std::vector<unsigned char> junk(bytes.begin(), bytes.begin() + 100);
    EXPECT_ERROR(slod::Rig::from_memory(world, junk.data(), junk.size()),
                 SLOD_RESULT_PARSE_ERROR);

    SlodCrowdDesc cd = slod_default_crowd_desc(); // LOD off
    slod::Crowd crowd(world, same, cd);
    same.reset(); // the crowd keeps the rig's data
    std::vector<SlodCharacterId> chars;
    for (int i = 0; i < 12; ++i) {
        SlodCharacterDesc d = slod_default_character_desc();
        d.position[0] = 1.5f * static_cast<float>(i % 4);
        d.position[2] = -1.5f * static_cast<float>(i / 4);
        d.time = 0.05f * static_cast<float>(i);
        chars.push_back(crowd.add(d));
    }
    EXPECT(crowd.size() == 12);
    world.set_camera(camera_at(4.0f));
    std::vector<slod::Mat4> before = crowd.model_matrices(chars[0]);
    EXPECT(before.size() == info.bones);
    SlodCrowdStats s = crowd.advance(1.0f / 30.0f);
    EXPECT(s.characters == 12);
    EXPECT(s.bones_held == 0); // LOD off: every animated bone interpolates
    EXPECT(s.bones_interpolated > 0);
    EXPECT(s.bones_interpolated + s.bones_held + s.bones_constant == 12ull * info.bones);
    std::vector<slod::Mat4> after = crowd.model_matrices(chars[0]);
    bool moved = false;
    for (size_t b = 0; b < after.size(); ++b)
        for (int k = 0; k < 16; ++k) {
            EXPECT(std::isfinite(after[b][k]));
            moved = moved || after[b][k] != before[b][k];
        }
    EXPECT(moved); // the clip plays
    EXPECT(after[0][15] == 1.0f); // column-major affine: element 15 is 1
    std::vector<slod::Mat4> skin = crowd.skinning_matrices(chars[0], 0);
    EXPECT(skin.size() == rig.skin_joint_count(0));
    EXPECT_ERROR(crowd.skinning_matrices(chars[0], 99), SLOD_RESULT_INVALID_ARGUMENT);

    // Bone structure, CPU skinning and the pose error over the C ABI (raw calls).
    size_t nb = 0;
    EXPECT(slod_rig_bone_parents(world.get(), rig.id(), nullptr, 0, &nb) == SLOD_RESULT_OK);
    EXPECT(nb == info.bones);
    std::vector<uint32_t> parents(nb);
    EXPECT(slod_rig_bone_parents(world.get(), rig.id(), parents.data(), nb, &nb) ==
           SLOD_RESULT_OK);
    for (size_t b = 0; b < nb; ++b) EXPECT(parents[b] == SLOD_NO_PARENT || parents[b] < b);
    size_t nv = 0;
    EXPECT(slod_character_skinned_vertices(world.get(), chars[0], 0, nullptr, nullptr, 0, &nv) ==
           SLOD_RESULT_OK);
    EXPECT(nv > 0);
    std::vector<float> pos(3 * nv), nrm(3 * nv);
    EXPECT(slod_character_skinned_vertices(world.get(), chars[0], 0, pos.data(), nrm.data(), nv,
                                           &nv) == SLOD_RESULT_OK);
    for (size_t i = 0; i < 3 * nv; ++i) EXPECT(std::isfinite(pos[i]) && std::isfinite(nrm[i]));
    // Held joints: the first update skins every vertex, and LOD off's pose equals it exactly.
    {
        SlodHeldSkin *held = nullptr;
        EXPECT(slod_held_skin_create(world.get(), chars[0], 0, &held) == SLOD_RESULT_OK);
        size_t redone = 0;
        EXPECT(slod_held_skin_update(world.get(), chars[0], held, 1.0f, &redone) == SLOD_RESULT_OK);
        EXPECT(redone == nv);
        EXPECT(slod_held_skin_update(world.get(), chars[0], held, NAN, &redone) ==
               SLOD_RESULT_INVALID_ARGUMENT);
        std::vector<float> hpos(3 * nv), hnrm(3 * nv);
        size_t hn = 0;
        EXPECT(slod_held_skin_vertices(held, hpos.data(), hnrm.data(), nv, &hn) == SLOD_RESULT_OK);
        EXPECT(hn == nv && hpos == pos);
        float ppu = -1.0f;
        EXPECT(slod_character_pixels_per_unit(world.get(), chars[0], &ppu) == SLOD_RESULT_OK);
        EXPECT(ppu >= 0.0f);
        slod_held_skin_destroy(held);
    }
    SlodPoseError err{};
    EXPECT(slod_character_pose_error(world.get(), chars[0], &err) == SLOD_RESULT_OK);
    EXPECT(err.max_px == 0.0f); // LOD off: exact

    // Distance range: everyone beyond max holds every bone.
    SlodLodDesc lod = slod_default_lod_desc();
    lod.mode = SLOD_LOD_MODE_RANGE;
    lod.range_min = 1.0f;
    lod.range_max = 10.0f;
    crowd.set_lod(lod);
    world.set_camera(camera_at(500.0f));
    s = crowd.advance(1.0f / 30.0f);
    EXPECT(s.bones_interpolated == 0);
    EXPECT(s.characters_frozen == 12);
    // Interpolated key poses: each key pose's palette is reachable, the weight is in [0, 1].
    SlodLodDesc keyed = slod_default_lod_desc();
    keyed.mode = SLOD_LOD_MODE_INTERPOLATED;
    keyed.max_error_px = 1.0f;
    crowd.set_lod(keyed);
    world.set_camera(camera_at(20.0f));
    for (int f = 0; f < 3; ++f) crowd.advance(1.0f / 60.0f);
    float weight = -1.0f;
    uint32_t update = 99;
    EXPECT(slod_character_key_state(world.get(), chars[0], &weight, &update) == SLOD_RESULT_OK);
    EXPECT(weight >= 0.0f && weight <= 1.0f && update <= SLOD_KEY_UPDATE_RESTARTED);
    std::vector<float> key_palette(16 * rig.skin_joint_count(0));
    size_t got = 0;
    EXPECT(slod_character_key_skinning_matrices(world.get(), chars[0], 0, true, key_palette.data(),
                                                rig.skin_joint_count(0), &got) == SLOD_RESULT_OK);
    EXPECT(got == rig.skin_joint_count(0));
    EXPECT(slod_character_key_skinning_matrices(world.get(), chars[0], 99, false, nullptr, 0,
                                                &got) == SLOD_RESULT_INVALID_ARGUMENT);
    lod.range_max = -1.0f;
    EXPECT_ERROR(crowd.set_lod(lod), SLOD_RESULT_INVALID_ARGUMENT);
    EXPECT(slod::last_error().find("range") != std::string::npos);
    EXPECT_ERROR(crowd.advance(NAN), SLOD_RESULT_INVALID_ARGUMENT);

    // Characters: remove one, its id goes stale; the rest stay.
    crowd.remove(chars[3]);
    EXPECT(crowd.size() == 11);
    EXPECT_ERROR(crowd.remove(chars[3]), SLOD_RESULT_STALE_ID);
    EXPECT_ERROR(crowd.set_position(chars[0], {INFINITY, 0.0f, 0.0f}),
                 SLOD_RESULT_INVALID_ARGUMENT);
    crowd.set_position(chars[0], {0.0f, 0.0f, 1.0f});
    SlodWorldCounts c = world.counts();
    EXPECT(c.crowds == 1 && c.characters == 11 && c.rigs == 1);
}

// Colliders, wind and a cloth worn by a character, through the plain C calls (slod.h): a
// capsule attached to a bone follows it, bad input is refused with the documented codes and
// changes nothing, a destroyed collider's id goes stale.
void engine_checks(slod::World &world, const char *rig_path) {
    SlodWorld *w = world.get();
    slod::Rig rig = slod::Rig::from_file(world, rig_path);
    slod::Crowd crowd(world, rig);
    SlodCharacterDesc chd = slod_default_character_desc();
    SlodCharacterId ch = crowd.add(chd);
    uint32_t torso = 0;
    EXPECT(slod_rig_find_bone(w, rig.id(), "torso", &torso) == SLOD_RESULT_OK);
    uint32_t none = 12345;
    EXPECT(slod_rig_find_bone(w, rig.id(), "no such bone", &none) ==
           SLOD_RESULT_INVALID_ARGUMENT);
    EXPECT(none == 12345); // outputs are written only on success

    SlodClothDesc d = slod_default_cloth_desc();
    d.columns = 9;
    d.rows = 9;
    d.spacing = 0.05f;
    d.center[1] = 0.6f;
    d.center[2] = -0.25f;
    d.axis_v[0] = 0.0f;
    d.axis_v[1] = -1.0f;
    d.axis_v[2] = 0.0f;
    slod::Cloth cape = slod::Cloth::grid(world, d);
    SlodColliderDesc cd = slod_default_collider_desc();
    cd.shape = SLOD_SHAPE_CAPSULE;
    cd.radius = 0.15f;
    cd.half_length = 0.1f;
    SlodColliderId body{};
    EXPECT(slod_cloth_collider_create(w, cape.id(), &cd, &body) == SLOD_RESULT_OK);
    SlodTransform local = {{0.0f, 0.2f, 0.0f}, {0.0f, 0.0f, 0.0f, 1.0f}};
    EXPECT(slod_cloth_collider_attach_to_bone(w, cape.id(), body, ch, torso, &local) ==
           SLOD_RESULT_OK);
    for (uint32_t i = 0; i < 9; ++i)
        EXPECT(slod_cloth_pin_vertex_to_bone(w, cape.id(), i, ch, torso,
                                             -0.2f + 0.05f * static_cast<float>(i), 0.3f,
                                             -0.25f) == SLOD_RESULT_OK);
    SlodWindDesc wind = slod_default_wind_desc();
    wind.velocity[2] = 3.0f;
    EXPECT(slod_cloth_set_wind(w, cape.id(), &wind) == SLOD_RESULT_OK);

    // Bad input: each refused with its code; the collider count does not change.
    SlodColliderDesc bad = cd;
    bad.radius = -1.0f;
    SlodColliderId unused{};
    EXPECT(slod_cloth_collider_create(w, cape.id(), &bad, &unused) ==
           SLOD_RESULT_INVALID_ARGUMENT);
    EXPECT(slod::last_error().find("radius") != std::string::npos);
    SlodColliderDesc zero{};
    EXPECT(slod_cloth_collider_create(w, cape.id(), &zero, &unused) ==
           SLOD_RESULT_INVALID_ARGUMENT);
    SlodTransform nan = {{NAN, 0.0f, 0.0f}, {0.0f, 0.0f, 0.0f, 1.0f}};
    EXPECT(slod_cloth_collider_set_transform(w, cape.id(), body, &nan) ==
           SLOD_RESULT_INVALID_ARGUMENT);
    EXPECT(slod_cloth_collider_attach_to_bone(w, cape.id(), body, ch, 100000, &local) ==
           SLOD_RESULT_INVALID_ARGUMENT);
    SlodCharacterId stale = ch;
    stale.generation += 1000;
    EXPECT(slod_cloth_pin_vertex_to_bone(w, cape.id(), 0, stale, torso, 0.0f, 0.0f, 0.0f) ==
           SLOD_RESULT_STALE_ID);
    SlodContactStats cs{};
    EXPECT(slod_cloth_contact_stats(w, cape.id(), &cs) == SLOD_RESULT_OK);
    EXPECT(cs.colliders == 1);

    // The character walks; the cape follows and stays finite, pressed on the body by the wind.
    world.set_camera(camera_at(3.0f));
    uint64_t touching = 0;
    for (int s = 0; s < 60; ++s) {
        crowd.advance(1.0f / 60.0f);
        cape.step();
        EXPECT(slod_cloth_contact_stats(w, cape.id(), &cs) == SLOD_RESULT_OK);
        touching += cs.touching_nodes;
        EXPECT(cs.collision_ms >= 0.0);
    }
    EXPECT(touching > 0);
    for (const slod::Vec3 &v : cape.vertex_positions()) EXPECT(finite(v));

    EXPECT(slod_cloth_collider_destroy(w, cape.id(), body) == SLOD_RESULT_OK);
    EXPECT(slod_cloth_collider_destroy(w, cape.id(), body) == SLOD_RESULT_STALE_ID);
    EXPECT(slod_cloth_contact_stats(w, cape.id(), &cs) == SLOD_RESULT_OK);
    EXPECT(cs.colliders == 0);
    EXPECT(slod_cloth_clear_wind(w, cape.id()) == SLOD_RESULT_OK);
    EXPECT(slod_cloth_detach_character(w, cape.id()) == SLOD_RESULT_OK);
}

// Handles share their world: a World moved into a variable declared after its handles (so it
// is destroyed first), or destroyed while handles live, must not be a use-after-free. Under
// valgrind (tests/tests/cpp_host.rs) any such access is an error.
void lifetime_checks() {
    std::optional<slod::Cloth> early;
    {
        slod::Cloth cloth = [] {
            slod::World w;
            return slod::Cloth::grid(w); // the World dies here, the Cloth keeps it alive
        }();
        cloth.step();
        EXPECT(cloth.vertex_positions().size() == 65u * 65u);
        early.emplace(std::move(cloth));
    }
    {
        slod::World first;
        slod::Cloth a = slod::Cloth::grid(first);
        slod::World later(std::move(first)); // declared after `a`: destroyed before it
        a.step();
        EXPECT(later.counts().cloths == 1);
    }
    early->step();
    early.reset();
    // A world with its own worker threads and parallel feedback: destroying it joins them
    // (valgrind reports no "possibly lost" thread stacks).
    {
        SlodWorldDesc wd = slod_default_world_desc();
        wd.worker_threads = 2;
        slod::World pooled(wd);
        slod::Cloth c = slod::Cloth::grid(pooled);
        SlodFeedbackDesc fd = slod_default_feedback_desc();
        fd.parallel = 1;
        fd.interval = 1;
        c.set_feedback(fd);
        for (int i = 0; i < 3; ++i) c.step();
    }
}

// Error messages name the call once and the detail once (no doubled code text).
void message_checks(slod::World &world) {
    SlodClothDesc bad = slod_default_cloth_desc();
    bad.spacing = -1.0f;
    try {
        (void)slod::Cloth::grid(world, bad);
        EXPECT(false);
    } catch (const slod::Error &e) {
        std::string m = e.what();
        EXPECT(m.rfind("slod_cloth_create_grid: ", 0) == 0);
        std::string code = slod_result_str(e.code());
        size_t first = m.find(code);
        EXPECT(first == std::string::npos || m.find(code, first + code.size()) == std::string::npos);
        EXPECT(m.find("desc.spacing") != std::string::npos);
    }
}

} // namespace

int main(int argc, char **argv) {
    if (argc < 2) {
        std::fprintf(stderr, "usage: host <rig.glb>\n");
        return 2;
    }
    EXPECT(slod_version() ==
           SLOD_VERSION_MAJOR * 1000000u + SLOD_VERSION_MINOR * 1000u + SLOD_VERSION_PATCH);
    try {
        SlodWorldDesc wd = slod_default_world_desc();
        wd.worker_threads = 1;
        slod::World world(wd);
        cloth_checks(world);
        crowd_checks(world, argv[1]);
        engine_checks(world, argv[1]);
        budget_checks(world);
        lifetime_checks();
        message_checks(world);
        SlodWorldCounts c = world.counts();
        EXPECT(c.cloths == 0 && c.crowds == 0 && c.rigs == 0 && c.characters == 0);

        // Ids from another world are refused.
        slod::World other(wd);
        slod::Cloth foreign = slod::Cloth::grid(other);
        size_t n = 0;
        EXPECT(slod_cloth_node_count(world.get(), foreign.id(), &n) == SLOD_RESULT_STALE_ID);
    } catch (const slod::Error &e) {
        std::fprintf(stderr, "unexpected slod::Error: %s\n", e.what());
        return 1;
    }
    if (failures != 0) {
        std::fprintf(stderr, "%d check(s) failed\n", failures);
        return 1;
    }
    std::printf("cpp host ok\n");
    return 0;
}
