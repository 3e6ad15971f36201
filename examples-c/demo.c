/* slod C demo harness: plain C11 against include/slod.h and the static library.
 *
 * 1. The swinging net: a 65x65 cloth pinned at its four corners, seen by a camera, with the
 *    feedback loop at 30% compression. Prints a summary line every 100 steps.
 * 2. A crowd of characters loaded from a glTF rig, the camera moving away from it step by step;
 *    prints how many bones interpolated and held per frame at each distance.
 * 3. A cape worn by one walking character: its top row pinned to the torso bone, six body
 *    colliders attached to bones, light wind; the crowd advances and the cape steps each frame.
 *
 * Usage: demo [--steps N] [--characters N] [--frames N] [--rig PATH]
 *   --steps       cloth steps (default 600)
 *   --characters  crowd size (default 100)
 *   --frames      frames advanced at each camera distance (default 30)
 *   --rig         glTF rig (default ../assets/gltf/GDQuest_GDBot.glb, relative to examples-c/)
 *
 * Every slod call is checked; on error the demo prints the code and slod_last_error and exits 1.
 * Everything created is destroyed explicitly before the world (valgrind-clean).
 */
#include "slod.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static void fail(const char *what, SlodResult r) {
    char msg[512];
    size_t len = 0;
    slod_last_error(msg, sizeof msg, &len);
    fprintf(stderr, "demo: %s failed: %s (%u): %s\n", what, slod_result_str(r), (unsigned)r, msg);
    exit(1);
}

#define CHECK(call)                                                                            \
    do {                                                                                       \
        SlodResult check_r_ = (call);                                                          \
        if (check_r_ != SLOD_RESULT_OK) fail(#call, check_r_);                                 \
    } while (0)

static double now_ms(void) {
    struct timespec ts;
    timespec_get(&ts, TIME_UTC);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

static SlodCamera look_at(float ex, float ey, float ez, float tx, float ty, float tz) {
    SlodCamera cam;
    memset(&cam, 0, sizeof cam);
    cam.position[0] = ex;
    cam.position[1] = ey;
    cam.position[2] = ez;
    cam.forward[0] = tx - ex;
    cam.forward[1] = ty - ey;
    cam.forward[2] = tz - ez;
    cam.up[1] = 1.0f;
    cam.fov_y_radians = 50.0f * 3.14159265f / 180.0f;
    cam.viewport_width = 1280;
    cam.viewport_height = 720;
    cam.near_plane = 0.05f;
    return cam;
}

/* Fetches a cloth's reconstructed finest vertices (size, then copy), as a renderer would: writes
 * their count, lowers *lowest to the lowest y, returns 1 if all are finite, 0 if not, -1 when
 * out of memory. */
static int surface(SlodWorld *world, SlodClothId cloth, size_t *count, float *lowest) {
    size_t nv = 0;
    SlodResult sized = slod_cloth_vertex_positions(world, cloth, NULL, 0, &nv);
    if (sized != SLOD_RESULT_OK) fail("sizing vertex buffer", sized);
    float *verts = malloc(3 * (nv ? nv : 1) * sizeof *verts); /* x, y, z per vertex */
    if (!verts) return -1;
    size_t written = 0;
    CHECK(slod_cloth_vertex_positions(world, cloth, verts, nv, &written));
    int finite = 1;
    for (size_t i = 0; i < written; ++i) {
        for (int k = 0; k < 3; ++k) finite &= isfinite(verts[3 * i + k]) ? 1 : 0;
        if (verts[3 * i + 1] < *lowest) *lowest = verts[3 * i + 1];
    }
    free(verts);
    *count = written;
    return finite;
}

/* The paper's net: 65 x 65 vertices 2 m wide, starting one level up, its four corners pinned
 * where they rest (vertex (i, j) is j * columns + i). */
static SlodClothId create_net(SlodWorld *world) {
    SlodClothDesc desc = slod_default_cloth_desc();
    desc.columns = 65;
    desc.rows = 65;
    desc.spacing = 2.0f / 64.0f;
    desc.initial_level = 1;
    SlodClothId cloth;
    CHECK(slod_cloth_create_grid(world, &desc, &cloth));
    const float half = 0.5f * (float)(desc.columns - 1) * desc.spacing;
    const unsigned c = desc.columns, r = desc.rows;
    const unsigned corners[4] = {0, c - 1, (r - 1) * c, r * c - 1};
    const float cx[4] = {-half, half, -half, half}, cz[4] = {-half, -half, half, half};
    for (int k = 0; k < 4; ++k) CHECK(slod_cloth_pin_vertex(world, cloth, corners[k], cx[k], 0.0f, cz[k]));
    return cloth;
}

static int run_net(SlodWorld *world, unsigned steps) {
    SlodClothId cloth = create_net(world);

    SlodCamera cam = look_at(0.0f, 0.6f, 3.2f, 0.0f, -0.5f, 0.0f);
    CHECK(slod_world_set_camera(world, &cam));
    SlodLight light = {SLOD_LIGHT_KIND_DIRECTIONAL, {0.3f, 1.0f, 0.5f}, 0.2f, 0.8f};
    CHECK(slod_world_set_light(world, &light));

    SlodFeedbackDesc fb = slod_default_feedback_desc();
    fb.budget_kind = SLOD_CLOTH_BUDGET_COMPRESSION;
    fb.budget_value = 0.3;
    CHECK(slod_cloth_set_feedback(world, cloth, &fb));

    /* Per 100-step window: wall time of the steps and the mean number of transitions in flight
     * (they last a few steps, so a single sample would mostly miss them). */
    double window_ms = 0.0;
    size_t window_interp = 0;
    for (unsigned s = 1; s <= steps; ++s) {
        double t0 = now_ms();
        CHECK(slod_cloth_step(world, cloth));
        window_ms += now_ms() - t0;
        size_t interp = 0;
        CHECK(slod_cloth_interpolations(world, cloth, &interp));
        window_interp += interp;
        if (s % 100 == 0 || s == steps) {
            size_t nodes = 0, links = 0;
            CHECK(slod_cloth_node_count(world, cloth, &nodes));
            CHECK(slod_cloth_link_count(world, cloth, &links));
            const double in_window = s % 100 == 0 ? 100.0 : (double)(s % 100);
            printf("net step %u nodes %zu links %zu interpolations %.2f ms/step %.3f\n", s, nodes,
                   links, (double)window_interp / in_window, window_ms / in_window);
            window_ms = 0.0;
            window_interp = 0;
        }
    }

    /* What a renderer would draw: the reconstructed full-resolution vertices. */
    size_t written = 0;
    float lowest = 0.0f;
    int finite = surface(world, cloth, &written, &lowest);
    if (finite < 0) return 1;

    /* Debug links with their blend weights. */
    size_t nl = 0;
    CHECK(slod_cloth_link_count(world, cloth, &nl));
    SlodDebugLink *dl = malloc((nl ? nl : 1) * sizeof *dl);
    if (!dl) return 1;
    size_t got_links = 0;
    CHECK(slod_cloth_links(world, cloth, dl, nl, &got_links));
    double weight_sum = 0.0;
    for (size_t i = 0; i < got_links; ++i) weight_sum += dl[i].weight;
    free(dl);

    SlodClothStats st;
    CHECK(slod_cloth_stats(world, cloth, &st));
    printf("net done steps %llu vertices %zu finite %d lowest %.3f links %zu mean_weight %.3f "
           "evaluations %llu refines %llu coarses %llu\n",
           (unsigned long long)st.steps, written, finite, lowest, got_links,
           got_links ? weight_sum / (double)got_links : 0.0, (unsigned long long)st.evaluations,
           (unsigned long long)st.refines, (unsigned long long)st.coarses);
    CHECK(slod_cloth_destroy(world, cloth));
    return finite ? 0 : 1;
}

/* A host at 120 Hz with a cloth stepped at 60 Hz: the cloth steps on even frames. Two
 * identical nets under a 1 px error bound: `ahead` runs its next step's evaluation on the frame
 * between (slod_cloth_evaluate_ahead), `inline` leaves it inside the step. Both see the same
 * view, so their positions stay bit-identical; what moves is the cost: the evaluation leaves the
 * step's frame. Prints each one's longest frame. */
static int run_high_refresh(SlodWorld *world, unsigned frames) {
    SlodClothId nets[2];
    SlodFeedbackDesc fb = slod_default_feedback_desc();
    fb.budget_kind = SLOD_CLOTH_BUDGET_MAX_ERROR_PX;
    fb.budget_value = 1.0;
    for (int n = 0; n < 2; ++n) {
        nets[n] = create_net(world);
        CHECK(slod_cloth_set_feedback(world, nets[n], &fb));
    }
    double longest[2] = {0.0, 0.0};
    unsigned ahead_runs = 0;
    /* Frames 0..frames (an even count): the last one steps both, so they are compared at the
     * same step (an evaluation run ahead begins its operations before its step). */
    for (unsigned f = 0; f <= frames; ++f) {
        for (int n = 0; n < 2; ++n) {
            double t0 = now_ms();
            if (f % 2 == 0) {
                CHECK(slod_cloth_step(world, nets[n]));
            } else if (n == 0) {
                bool ran = false;
                CHECK(slod_cloth_evaluate_ahead(world, nets[n], &ran));
                ahead_runs += ran;
            }
            double ms = now_ms() - t0;
            /* The first second is the cold start (the cut shaping itself): not counted. */
            if (f >= 120 && ms > longest[n]) longest[n] = ms;
        }
    }
    const size_t count = 65 * 65;
    float *pos[2] = {malloc(3 * count * sizeof(float)), malloc(3 * count * sizeof(float))};
    if (!pos[0] || !pos[1]) return 1;
    for (int n = 0; n < 2; ++n) {
        size_t written = 0;
        CHECK(slod_cloth_vertex_positions(world, nets[n], pos[n], count, &written));
    }
    int same = memcmp(pos[0], pos[1], 3 * count * sizeof(float)) == 0;
    free(pos[0]);
    free(pos[1]);
    printf("high_refresh frames %u evaluations_ahead %u identical %d longest_ahead_ms %.3f "
           "longest_inline_ms %.3f\n",
           frames, ahead_runs, same, longest[0], longest[1]);
    for (int n = 0; n < 2; ++n) CHECK(slod_cloth_destroy(world, nets[n]));
    return same ? 0 : 1;
}

/* A cloth stepped alone, its evaluations overlapped with their steps (feedback desc
 * `overlap_step` 1): each evaluation's measurement runs on another worker thread while the
 * step's solver runs, and its operations begin after that step. The same net in a world of two
 * worker threads (`parallel` 1: the measurement beside the solver) and in `world` (one thread:
 * the two one after the other) ends bit-identical; a third net, evaluating before its steps as
 * usual, shows the cost the overlap takes off. Prints the slowest evaluating step of each. */
static int run_overlap(SlodWorld *world, unsigned steps) {
    SlodWorldDesc wd = slod_default_world_desc();
    wd.worker_threads = 2;
    SlodWorld *pair = NULL;
    CHECK(slod_world_create(&wd, &pair));
    SlodCamera cam = look_at(0.0f, 0.6f, 3.2f, 0.0f, -0.5f, 0.0f);
    CHECK(slod_world_set_camera(pair, &cam));
    CHECK(slod_world_set_camera(world, &cam));
    SlodWorld *worlds[3] = {pair, world, pair};
    SlodFeedbackDesc fb = slod_default_feedback_desc();
    fb.budget_kind = SLOD_CLOTH_BUDGET_MAX_ERROR_PX;
    fb.budget_value = 1.0;
    fb.parallel = 1;
    SlodClothId nets[3];
    for (int n = 0; n < 3; ++n) {
        fb.overlap_step = n < 2;
        nets[n] = create_net(worlds[n]);
        CHECK(slod_cloth_set_feedback(worlds[n], nets[n], &fb));
    }
    double longest[3] = {0.0, 0.0, 0.0};
    for (unsigned s = 0; s < steps; ++s) {
        for (int n = 0; n < 3; ++n) {
            double t0 = now_ms();
            CHECK(slod_cloth_step(worlds[n], nets[n]));
            double ms = now_ms() - t0;
            /* Evaluating steps only (every 5th, from the first), after the cold start. */
            if (s >= 60 && s % 5 == 0 && ms > longest[n]) longest[n] = ms;
        }
    }
    const size_t count = 65 * 65;
    float *pos[2] = {malloc(3 * count * sizeof(float)), malloc(3 * count * sizeof(float))};
    if (!pos[0] || !pos[1]) return 1;
    for (int n = 0; n < 2; ++n) {
        size_t written = 0;
        CHECK(slod_cloth_vertex_positions(worlds[n], nets[n], pos[n], count, &written));
    }
    int same = memcmp(pos[0], pos[1], 3 * count * sizeof(float)) == 0;
    free(pos[0]);
    free(pos[1]);
    printf("overlap steps %u identical %d longest_overlapped_ms %.3f longest_one_thread_ms %.3f "
           "longest_sequential_ms %.3f\n",
           steps, same, longest[0], longest[1], longest[2]);
    for (int n = 0; n < 3; ++n) CHECK(slod_cloth_destroy(worlds[n], nets[n]));
    slod_world_destroy(pair);
    return same ? 0 : 1;
}

static int run_crowd(SlodWorld *world, const char *rig_path, unsigned characters, unsigned frames) {
    SlodRigId rig;
    CHECK(slod_rig_load_file(world, rig_path, &rig));
    SlodRigInfo info;
    CHECK(slod_rig_info(world, rig, &info));
    /* Clip: a walk if the rig has one, else clip 0. */
    uint32_t clip = 0;
    if (slod_rig_find_clip(world, rig, "walk", &clip) != SLOD_RESULT_OK) clip = 0;
    char clip_name[128];
    size_t name_len = 0;
    CHECK(slod_rig_clip_name(world, rig, clip, clip_name, sizeof clip_name, &name_len));
    printf("crowd rig bones %u clips %u skins %u radius %.3f clip %s\n", info.bones, info.clips,
           info.skins, info.bounds_radius, clip_name);

    /* The camera stands in front of the crowd (+z) looking at its centre and moves away.
     * Distances in units of the rig's size, so any rig works: full detail within 4 radii,
     * nothing interpolates beyond 60. */
    const float rad = info.bounds_radius > 0.0f ? info.bounds_radius : 1.0f;
    SlodCrowdDesc cd = slod_default_crowd_desc();
    cd.lod.mode = SLOD_LOD_MODE_RANGE;
    cd.lod.range_min = 4.0f * rad;
    cd.lod.range_max = 60.0f * rad;
    SlodCrowdId crowd;
    CHECK(slod_crowd_create(world, rig, &cd, &crowd));

    SlodCharacterId *ids = malloc((characters ? characters : 1) * sizeof *ids);
    if (!ids) return 1;
    const unsigned side = (unsigned)ceil(sqrt((double)characters));
    const float spacing = 2.5f * rad;
    const float depth = (float)(side - 1) * spacing; /* rows run from z = 0 to z = -depth */
    for (unsigned i = 0; i < characters; ++i) {
        SlodCharacterDesc ch = slod_default_character_desc();
        ch.position[0] = ((float)(i % side) - 0.5f * (float)(side - 1)) * spacing;
        ch.position[2] = -((float)(i / side)) * spacing;
        ch.clip = clip;
        ch.time = 0.037f * (float)i; /* out of phase */
        CHECK(slod_character_create(world, crowd, &ch, &ids[i]));
    }
    size_t live = 0;
    CHECK(slod_crowd_character_count(world, crowd, &live));
    printf("crowd characters %zu\n", live);

    const float distances[] = {2.0f, 5.0f, 10.0f, 20.0f, 40.0f, 80.0f};
    const float dt = 1.0f / 60.0f;
    for (size_t d = 0; d < sizeof distances / sizeof distances[0]; ++d) {
        float dist = distances[d] * rad;
        SlodCamera cam = look_at(0.0f, info.bounds_center[1], dist, 0.0f, info.bounds_center[1],
                                 -0.5f * depth);
        CHECK(slod_world_set_camera(world, &cam));
        unsigned long long interp = 0, held = 0, frozen = 0;
        double t0 = now_ms();
        for (unsigned f = 0; f < frames; ++f) {
            SlodCrowdStats s;
            CHECK(slod_crowd_advance(world, crowd, dt, &s));
            interp += s.bones_interpolated;
            held += s.bones_held;
            frozen += s.characters_frozen;
        }
        const double n = frames ? (double)frames : 1.0;
        const double ms = (now_ms() - t0) / n;
        printf("crowd distance %.1f interpolated %.1f held %.1f frozen %.1f ms/frame %.3f\n", dist,
               (double)interp / n, (double)held / n, (double)frozen / n, ms);
    }

    /* A crowd-wide budget: the budget's units (a character interpolated whole through the
     * block path counts a sixth of its bones) never exceed it; the bones interpolated may. */
    {
        SlodCamera cam = look_at(0.0f, info.bounds_center[1], 10.0f * rad, 0.0f,
                                 info.bounds_center[1], -0.5f * depth);
        CHECK(slod_world_set_camera(world, &cam));
        SlodLodDesc lod = cd.lod;
        lod.mode = SLOD_LOD_MODE_BUDGET;
        lod.bone_updates_per_frame = 8u * (characters ? characters : 1u);
        CHECK(slod_crowd_set_lod(world, crowd, &lod));
        unsigned long long units = 0, interp = 0, over = 0;
        for (unsigned f = 0; f < frames; ++f) {
            SlodCrowdStats s;
            CHECK(slod_crowd_advance(world, crowd, dt, &s));
            units += s.budget_units;
            interp += s.bones_interpolated;
            over += s.budget_units > lod.bone_updates_per_frame;
        }
        const double n = frames ? (double)frames : 1.0;
        printf("crowd budget %u units %.1f interpolated %.1f over %llu\n",
               lod.bone_updates_per_frame, (double)units / n, (double)interp / n, over);
        if (over) fail("budget overspent", SLOD_RESULT_INVALID_ARGUMENT);
        lod.mode = SLOD_LOD_MODE_RANGE;
        CHECK(slod_crowd_set_lod(world, crowd, &lod));
    }

    /* Joint matrices of the first character, as a renderer would fetch them. */
    int finite = 1;
    if (characters > 0) {
        size_t nb = 0;
        SlodResult sized = slod_character_model_matrices(world, ids[0], NULL, 0, &nb);
        if (sized != SLOD_RESULT_OK) fail("sizing matrix buffer", sized);
        float *m = malloc(16 * nb * sizeof *m); /* 16 floats per bone, column-major */
        if (!m) return 1;
        size_t got = 0;
        CHECK(slod_character_model_matrices(world, ids[0], m, nb, &got));
        for (size_t i = 0; i < got; ++i)
            for (int k = 0; k < 16; ++k) finite &= isfinite(m[16 * i + k]) ? 1 : 0;
        free(m);
        if (info.skins > 0) {
            size_t nj = 0;
            CHECK(slod_rig_skin_joint_count(world, rig, 0, &nj));
            float *sk = malloc(16 * (nj ? nj : 1) * sizeof *sk);
            if (!sk) return 1;
            CHECK(slod_character_skinning_matrices(world, ids[0], 0, sk, nj, &got));
            for (size_t i = 0; i < got; ++i)
                for (int k = 0; k < 16; ++k) finite &= isfinite(sk[16 * i + k]) ? 1 : 0;
            /* Interpolated key poses: a host skins each key pose once (its palette here) and
             * blends the two skinned copies with the weight. */
            float weight = 0.0f;
            uint32_t update = 0;
            CHECK(slod_character_key_state(world, ids[0], &weight, &update));
            CHECK(slod_character_key_skinning_matrices(world, ids[0], 0, true, sk, nj, &got));
            for (size_t i = 0; i < got; ++i)
                for (int k = 0; k < 16; ++k) finite &= isfinite(sk[16 * i + k]) ? 1 : 0;
            finite &= weight >= 0.0f && weight <= 1.0f && update <= SLOD_KEY_UPDATE_RESTARTED;
            free(sk);
        }
        printf("crowd matrices bones %zu finite %d\n", nb, finite);

        /* What a host needs to map the matrices to its own mesh: parents and names of the bones,
         * the skin's joint -> bone map; then the rig's mesh skinned on the CPU, and the error of
         * the LOD pose (joint origins and tips, pixels through the world's camera). */
        uint32_t *parents = malloc(nb * sizeof *parents);
        if (!parents) return 1;
        CHECK(slod_rig_bone_parents(world, rig, parents, nb, &got));
        int ordered = 1;
        for (size_t i = 0; i < got; ++i)
            ordered &= parents[i] == SLOD_NO_PARENT || parents[i] < i;
        free(parents);
        char bone0[128];
        CHECK(slod_rig_bone_name(world, rig, 0, bone0, sizeof bone0, &name_len));
        size_t meshes = 0, nv = 0;
        CHECK(slod_rig_mesh_count(world, rig, &meshes));
        int skinned_finite = 1;
        if (meshes > 0) {
            CHECK(slod_character_skinned_vertices(world, ids[0], 0, NULL, NULL, 0, &nv));
            float *pos = malloc(3 * (nv ? nv : 1) * sizeof *pos); /* x, y, z per vertex */
            float *nrm = malloc(3 * (nv ? nv : 1) * sizeof *nrm);
            if (!pos || !nrm) return 1;
            CHECK(slod_character_skinned_vertices(world, ids[0], 0, pos, nrm, nv, &got));
            for (size_t i = 0; i < got; ++i)
                for (int k = 0; k < 3; ++k)
                    skinned_finite &= isfinite(pos[3 * i + k]) && isfinite(nrm[3 * i + k]) ? 1 : 0;
            /* Skinning with held joints: the object keeps the output; each update skins again
             * only vertices of joints that moved past 1 px there (the first skins them all). */
            SlodHeldSkin *held = NULL;
            size_t redone = 0;
            float ppu = 0.0f;
            CHECK(slod_held_skin_create(world, ids[0], 0, &held));
            CHECK(slod_held_skin_update(world, ids[0], held, 1.0f, &redone));
            CHECK(slod_character_pixels_per_unit(world, ids[0], &ppu));
            skinned_finite &= redone == nv && ppu >= 0.0f;
            CHECK(slod_held_skin_vertices(held, pos, nrm, nv, &got));
            for (size_t i = 0; i < got; ++i)
                for (int k = 0; k < 3; ++k)
                    skinned_finite &= isfinite(pos[3 * i + k]) && isfinite(nrm[3 * i + k]) ? 1 : 0;
            slod_held_skin_destroy(held);
            /* Shared poses: each character's candidate phase bucket within 1 px, prepared
             * together (poses worth sharing are skinned once and kept), then a shared
             * character shows its bucket's vertices and the crowd skips its pose. */
            SlodPoseShare *share = NULL;
            CHECK(slod_pose_share_create(world, ids[0], 64, &share));
            SlodSharedPose pose[2];
            bool has[2];
            uint8_t flag[2];
            for (int i = 0; i < 2; ++i) {
                CHECK(slod_pose_share_request(world, ids[i], share, 1.0f, &pose[i], &has[i]));
                flag[i] = has[i] ? 1 : 0;
            }
            SlodPoseShareStats ps;
            CHECK(slod_pose_share_prepare(share, pose, flag, 2, &ps));
            for (int i = 0; i < 2; ++i) {
                CHECK(slod_character_set_pose_shared(world, ids[i], flag[i] != 0));
                if (flag[i]) {
                    CHECK(slod_pose_share_vertices(share, pose[i], pos, nrm, nv, &got));
                    skinned_finite &= got == nv;
                }
            }
            CHECK(slod_character_set_pose_shared(world, ids[0], false));
            CHECK(slod_character_set_pose_shared(world, ids[1], false));
            printf("shared poses used %u skinned %u\n", ps.poses_used, ps.poses_skinned);
            slod_pose_share_destroy(share);
            free(pos);
            free(nrm);
        }
        CHECK(slod_character_set_play_once(world, ids[0], true));
        SlodPoseError err;
        CHECK(slod_crowd_pose_error(world, crowd, &err));
        printf("crowd bones ordered %d first %s meshes %zu vertices %zu skinned_finite %d "
               "error_max_px %.3f\n",
               ordered, bone0, meshes, nv, skinned_finite, err.max_px);
    }

    /* Tear down explicitly: half the characters one by one, the rest with their crowd. */
    for (unsigned i = 0; i < characters / 2; ++i) CHECK(slod_character_destroy(world, ids[i]));
    free(ids);
    CHECK(slod_crowd_destroy(world, crowd));
    CHECK(slod_rig_destroy(world, rig));
    return finite ? 0 : 1;
}

/* Index of a bone of the rig, by name. */
static uint32_t bone(SlodWorld *world, SlodRigId rig, const char *name) {
    uint32_t b = 0;
    CHECK(slod_rig_find_bone(world, rig, name, &b));
    return b;
}

static int run_cape(SlodWorld *world, const char *rig_path, unsigned steps) {
    SlodRigId rig;
    CHECK(slod_rig_load_file(world, rig_path, &rig));
    uint32_t walk = 0;
    if (slod_rig_find_clip(world, rig, "walk", &walk) != SLOD_RESULT_OK) walk = 0;
    SlodCrowdId crowd;
    SlodCrowdDesc cd = slod_default_crowd_desc();
    CHECK(slod_crowd_create(world, rig, &cd, &crowd));
    SlodCharacterDesc chd = slod_default_character_desc();
    chd.clip = walk;
    SlodCharacterId ch;
    CHECK(slod_character_create(world, crowd, &chd, &ch));

    /* A 0.5 m x 0.6 m cape of 17x17 vertices hanging behind the character (GDBot is about 1.1 m
     * tall and faces +z). */
    const unsigned n = 17;
    SlodClothDesc d = slod_default_cloth_desc();
    d.columns = n;
    d.rows = n;
    d.spacing = 0.5f / (float)(n - 1);
    d.total_mass = 0.15f;
    d.center[0] = 0.0f;
    d.center[1] = 0.58f;
    d.center[2] = -0.2f;
    d.axis_u[0] = 1.0f;
    d.axis_u[1] = 0.0f;
    d.axis_u[2] = 0.0f;
    d.axis_v[0] = 0.0f;
    d.axis_v[1] = -1.0f;
    d.axis_v[2] = 0.0f;
    d.initial_level = 0;
    SlodClothId cape;
    CHECK(slod_cloth_create_grid(world, &d, &cape));
    SlodFeedbackDesc fb = slod_default_feedback_desc();
    fb.budget_kind = SLOD_CLOTH_BUDGET_COMPRESSION;
    fb.budget_value = 0.3;
    CHECK(slod_cloth_set_feedback(world, cape, &fb));

    /* The top row hangs from the torso bone (its origin is about 0.515 m up at rest). */
    const uint32_t torso = bone(world, rig, "torso");
    const float half = 0.5f * (float)(n - 1) * d.spacing;
    for (unsigned i = 0; i < n; ++i) {
        float x = -half + (float)i * d.spacing;
        CHECK(slod_cloth_pin_vertex_to_bone(world, cape, i, ch, torso, x, 0.83f - 0.515f, -0.2f));
    }
    /* Body colliders on bones; +y runs along each bone. */
    struct {
        const char *bone;
        uint32_t shape;
        float radius, half_length, along;
    } body[] = {
        {"torso", SLOD_SHAPE_CAPSULE, 0.15f, 0.1f, 0.2f},
        {"head", SLOD_SHAPE_SPHERE, 0.16f, 0.0f, 0.12f},
        {"upperleg.L", SLOD_SHAPE_CAPSULE, 0.07f, 0.06f, 0.07f},
        {"upperleg.R", SLOD_SHAPE_CAPSULE, 0.07f, 0.06f, 0.07f},
        {"lowerleg.L", SLOD_SHAPE_CAPSULE, 0.06f, 0.08f, 0.1f},
        {"lowerleg.R", SLOD_SHAPE_CAPSULE, 0.06f, 0.08f, 0.1f},
    };
    const unsigned colliders = sizeof body / sizeof body[0];
    for (unsigned k = 0; k < colliders; ++k) {
        SlodColliderDesc cdsc = slod_default_collider_desc();
        cdsc.shape = body[k].shape;
        cdsc.radius = body[k].radius;
        cdsc.half_length = body[k].half_length;
        cdsc.friction = 0.4f;
        SlodColliderId id;
        CHECK(slod_cloth_collider_create(world, cape, &cdsc, &id));
        SlodTransform local = {{0.0f, body[k].along, 0.0f}, {0.0f, 0.0f, 0.0f, 1.0f}};
        CHECK(slod_cloth_collider_attach_to_bone(world, cape, id, ch, bone(world, rig, body[k].bone),
                                                 &local));
    }
    SlodWindDesc wind = slod_default_wind_desc();
    wind.velocity[0] = 1.0f;
    wind.velocity[2] = 2.0f; /* towards the character: the cape presses on its back */
    CHECK(slod_cloth_set_wind(world, cape, &wind));

    SlodCamera cam = look_at(1.4f, 1.0f, -2.0f, 0.0f, 0.55f, 0.0f);
    CHECK(slod_world_set_camera(world, &cam));
    unsigned long long touching = 0;
    double collision_ms = 0.0;
    for (unsigned s = 0; s < steps; ++s) {
        CHECK(slod_crowd_advance(world, crowd, 1.0f / 60.0f, NULL));
        CHECK(slod_cloth_step(world, cape));
        SlodContactStats cs;
        CHECK(slod_cloth_contact_stats(world, cape, &cs));
        touching += cs.touching_nodes;
        collision_ms += cs.collision_ms;
    }
    size_t nv = 0;
    float lowest = 1e9f;
    int finite = surface(world, cape, &nv, &lowest);
    if (finite < 0) return 1;
    const double sn = steps ? (double)steps : 1.0;
    printf("cape steps %u vertices %zu colliders %u touching %.1f collision_ms %.3f finite %d "
           "lowest %.3f\n",
           steps, nv, colliders, (double)touching / sn, collision_ms / sn, finite, lowest);
    CHECK(slod_cloth_destroy(world, cape));
    CHECK(slod_crowd_destroy(world, crowd));
    CHECK(slod_rig_destroy(world, rig));
    return finite ? 0 : 1;
}

/* The world step under one frame budget: three hanging cloths at 2, 6 and 18 m and a crowd,
 * stepped together by slod_world_step under a deterministic cost-unit budget (the world was
 * created with one worker thread, so the run is reproducible). The budget is five times what the
 * coarse start costs; the near cloth is forced to full detail (a host override). */
static int run_world(SlodWorld *world, const char *rig_path, unsigned frames) {
    const float dist[3] = {2.0f, 6.0f, 18.0f};
    SlodClothId cloths[3];
    for (int k = 0; k < 3; ++k) {
        SlodClothDesc desc = slod_default_cloth_desc();
        desc.columns = 17;
        desc.rows = 17;
        desc.spacing = 1.2f / 16.0f;
        desc.center[0] = (float)k - 1.0f;
        desc.center[1] = 1.2f;
        desc.center[2] = -dist[k];
        desc.axis_u[0] = 1.0f; desc.axis_u[1] = 0.0f; desc.axis_u[2] = 0.0f;
        desc.axis_v[0] = 0.0f; desc.axis_v[1] = -1.0f; desc.axis_v[2] = 0.0f;
        desc.initial_level = 2;
        CHECK(slod_cloth_create_grid(world, &desc, &cloths[k]));
        /* Pin the top row where it rests: vertex (i, 0) is i. */
        size_t n = 0;
        float *all = malloc(3 * 17 * 17 * sizeof *all);
        if (!all) return 1;
        CHECK(slod_cloth_vertex_positions(world, cloths[k], all, 17 * 17, &n));
        for (unsigned i = 0; i < 17; ++i) {
            CHECK(slod_cloth_pin_vertex(world, cloths[k], i, all[3 * i], all[3 * i + 1],
                                        all[3 * i + 2]));
        }
        free(all);
        SlodWindDesc wind = slod_default_wind_desc();
        wind.velocity[0] = 1.0f;
        wind.velocity[2] = 3.0f;
        CHECK(slod_cloth_set_wind(world, cloths[k], &wind));
    }
    SlodRigId rig;
    CHECK(slod_rig_load_file(world, rig_path, &rig));
    SlodCrowdDesc cd = slod_default_crowd_desc();
    SlodCrowdId crowd;
    CHECK(slod_crowd_create(world, rig, &cd, &crowd));
    for (unsigned i = 0; i < 20; ++i) {
        SlodCharacterDesc ch = slod_default_character_desc();
        ch.position[0] = (float)(i % 5) - 2.0f;
        ch.position[2] = -3.0f - 2.0f * (float)i;
        ch.time = 0.41f * (float)i;
        SlodCharacterId id;
        CHECK(slod_character_create(world, crowd, &ch, &id));
    }
    SlodCamera cam = look_at(0.0f, 1.6f, 3.0f, 0.0f, 1.0f, -10.0f);
    CHECK(slod_world_set_camera(world, &cam));

    /* One frame without a budget measures the coarse start. */
    SlodWorldStepStats s;
    CHECK(slod_world_step(world, 1.0f / 60.0f, &s));
    SlodWorldBudgetDesc b = slod_default_world_budget_desc();
    b.target_kind = SLOD_WORLD_BUDGET_KIND_COST_UNITS;
    b.target_units = 5.0 * s.cost_units;
    CHECK(slod_world_set_budget(world, &b));
    CHECK(slod_world_set_cloth_share(world, cloths[0], SLOD_BUDGET_SHARE_FULL_DETAIL, 1.0f));

    /* Bad input is refused and changes nothing. */
    SlodWorldBudgetDesc bad = b;
    bad.target_kind = SLOD_WORLD_BUDGET_KIND_MILLISECONDS;
    bad.target_ms = 0.0f;
    int refused = slod_world_set_budget(world, &bad) == SLOD_RESULT_INVALID_ARGUMENT;
    refused &= slod_world_set_cloth_share(world, cloths[1], SLOD_BUDGET_SHARE_SHARED, -1.0f) ==
               SLOD_RESULT_INVALID_ARGUMENT;
    refused &= slod_world_step(world, -1.0f, NULL) == SLOD_RESULT_INVALID_ARGUMENT;

    double tail = 0.0;
    unsigned tail_frames = 0;
    for (unsigned f = 0; f < frames; ++f) {
        CHECK(slod_world_step(world, 1.0f / 60.0f, &s));
        if (f + 30 >= frames) {
            tail += s.measured / b.target_units;
            ++tail_frames;
        }
    }
    size_t forced = 0, forced_full = 0;
    CHECK(slod_cloth_node_count(world, cloths[0], &forced));
    CHECK(slod_cloth_vertex_count(world, cloths[0], &forced_full));
    float bound = 0.0f;
    CHECK(slod_world_error_bound(world, &bound));
    printf("world frames %u bound %.3f cost_ratio %.3f nodes %llu forced_full %d refused %d\n",
           frames, bound, tail_frames ? tail / tail_frames : 0.0,
           (unsigned long long)s.cloth_nodes, forced == forced_full, refused);
    for (int k = 0; k < 3; ++k) CHECK(slod_cloth_destroy(world, cloths[k]));
    CHECK(slod_crowd_destroy(world, crowd));
    CHECK(slod_rig_destroy(world, rig));
    return 0;
}

int main(int argc, char **argv) {
    unsigned steps = 600, characters = 100, frames = 30;
    const char *rig = "../assets/gltf/GDQuest_GDBot.glb";
    for (int i = 1; i < argc; ++i) {
        if (i + 1 < argc && strcmp(argv[i], "--steps") == 0) {
            steps = (unsigned)strtoul(argv[++i], NULL, 10);
        } else if (i + 1 < argc && strcmp(argv[i], "--characters") == 0) {
            characters = (unsigned)strtoul(argv[++i], NULL, 10);
        } else if (i + 1 < argc && strcmp(argv[i], "--frames") == 0) {
            frames = (unsigned)strtoul(argv[++i], NULL, 10);
        } else if (i + 1 < argc && strcmp(argv[i], "--rig") == 0) {
            rig = argv[++i];
        } else {
            fprintf(stderr, "usage: %s [--steps N] [--characters N] [--frames N] [--rig PATH]\n",
                    argv[0]);
            return 2;
        }
    }

    uint32_t v = slod_version();
    printf("slod %u.%u.%u (header %d.%d.%d)\n", v / 1000000u, v / 1000u % 1000u, v % 1000u,
           SLOD_VERSION_MAJOR, SLOD_VERSION_MINOR, SLOD_VERSION_PATCH);

    SlodWorldDesc wd = slod_default_world_desc();
    wd.worker_threads = 1; /* everything on this thread: deterministic, no pool to tear down */
    SlodWorld *world = NULL;
    CHECK(slod_world_create(&wd, &world));

    int status = run_net(world, steps);
    if (status == 0) status = run_crowd(world, rig, characters, frames);
    if (status == 0) status = run_cape(world, rig, steps < 120 ? steps : 120);
    if (status == 0) status = run_world(world, rig, steps < 240 ? steps : 240);
    if (status == 0) status = run_high_refresh(world, steps < 240 ? 2 * steps : 480);
    if (status == 0) status = run_overlap(world, steps < 240 ? steps : 240);

    SlodWorldCounts counts;
    CHECK(slod_world_counts(world, &counts));
    printf("world left cloths %u rigs %u crowds %u characters %u\n", counts.cloths, counts.rigs,
           counts.crowds, counts.characters);
    slod_world_destroy(world);
    if (status == 0) printf("demo ok\n");
    return status;
}
