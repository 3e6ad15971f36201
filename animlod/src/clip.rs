//! Animation clips: per-bone translation, rotation and scale channels with their key times, stored
//! for fast playback.
//!
//! Layout (what makes sampling fast):
//! - Channels whose keys never change (within a tolerance) are *constant*: their value is folded
//!   into the clip's base pose at load time and they are never sampled again. Real exports key
//!   every property of every joint and most of those channels never move.
//! - The remaining channels are grouped into *blocks* by property, key-time array and
//!   interpolation. Channels that share key times (all of them, in a Blender export) share one
//!   segment search per frame, and a block stores its keys key-major (`keys[k * channels + c]`), so
//!   sampling segment `k` reads two contiguous rows.
//! - Rotation keys are put in one hemisphere at load time (key `k + 1` negated when its dot
//!   product with key `k` is negative, tangents too for cubic splines), so `q` followed by `−q` —
//!   the same rotation, common in real files — interpolates as "no motion" and playback needs no
//!   sign test.

use glam::{Affine3A, Quat, Vec3, Vec3A, Vec4};

use crate::error::BuildError;
use crate::ids::BoneId;
use crate::skeleton::Skeleton;
use crate::transform::{Transform, compose, compose4};

pub use crate::sampling::Interpolation;
pub(crate) use crate::sampling::{Block, ChannelRef, Cursor, TrsScratch, locate};

/// The property of a bone's local transform that a channel animates.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Property {
    /// Translation relative to the parent.
    Translation,
    /// Rotation relative to the parent.
    Rotation,
    /// Scale.
    Scale,
}

impl Property {
    /// Position of the property in per-property arrays (`[translation, rotation, scale]`).
    #[inline]
    pub fn slot(self) -> usize {
        match self {
            Property::Translation => 0,
            Property::Rotation => 1,
            Property::Scale => 2,
        }
    }

    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Property::Translation => "translation",
            Property::Rotation => "rotation",
            Property::Scale => "scale",
        }
    }
}

/// The values of a channel. For [`Interpolation::CubicSpline`] there are three values per key, in
/// glTF order: in-tangent, value, out-tangent.
#[derive(Clone, Debug, PartialEq)]
pub enum Keys {
    /// Translation values.
    Translation(Vec<Vec3>),
    /// Rotation values (any length; normalised on load).
    Rotation(Vec<Quat>),
    /// Scale values.
    Scale(Vec<Vec3>),
}

impl Keys {
    fn property(&self) -> Property {
        match self {
            Keys::Translation(_) => Property::Translation,
            Keys::Rotation(_) => Property::Rotation,
            Keys::Scale(_) => Property::Scale,
        }
    }

    fn len(&self) -> usize {
        match self {
            Keys::Translation(v) | Keys::Scale(v) => v.len(),
            Keys::Rotation(v) => v.len(),
        }
    }
}

/// One animated property of one bone, as handed to [`Clip::new`].
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelDesc {
    /// The bone animated.
    pub bone: BoneId,
    /// How to interpolate between keys.
    pub interpolation: Interpolation,
    /// Key times in seconds, finite and non-decreasing.
    pub times: Vec<f32>,
    /// Key values (three per key for cubic splines).
    pub keys: Keys,
}

/// Load-time options for clips.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClipOptions {
    /// A rotation or scale channel whose every key equals its first key within this absolute
    /// tolerance (per component; tangents of cubic splines must be within it of zero) is constant
    /// and never sampled. A negative value disables the detection for every property (every
    /// multi-key channel is sampled, as a runtime without this optimisation would), which
    /// benchmarks use as a reference.
    pub constant_tolerance: f32,
    /// The same for translation channels, in model units ([`crate::build::scaled`] scales it with
    /// the rig, so a rig in centimetres keeps the constant channels it had in metres).
    pub translation_tolerance: f32,
}

impl Default for ClipOptions {
    fn default() -> Self {
        ClipOptions {
            constant_tolerance: 1e-6,
            translation_tolerance: 1e-6,
        }
    }
}

impl ClipOptions {
    /// Constant-channel detection off (every multi-key channel is sampled).
    pub const SAMPLE_ALL: ClipOptions = ClipOptions {
        constant_tolerance: -1.0,
        translation_tolerance: -1.0,
    };
}

/// How many channels of a clip were keyed, and how many of those turned out constant, per
/// property (`[translation, rotation, scale]`, see [`Property::slot`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ChannelStats {
    /// Channels present in the clip, per property.
    pub keyed: [u32; 3],
    /// Of those, channels whose keys never change (folded into the base pose, never sampled).
    pub constant: [u32; 3],
    /// Rotation key pairs that were written as `q` then (nearly) `−q`, i.e. with a negative dot
    /// product, and were put back in one hemisphere.
    pub hemisphere_flips: u32,
}

impl ChannelStats {
    /// Constant channels of a property.
    #[cfg(test)]
    pub(crate) fn constant(&self, p: Property) -> u32 {
        self.constant[p.slot()]
    }

    /// Channels that are sampled at run time.
    pub fn animated(&self) -> u32 {
        (0..3).map(|i| self.keyed[i] - self.constant[i]).sum()
    }
}

/// An animation clip bound to a skeleton: constant channels folded into a base pose, animated
/// channels in blocks. Plain runtime data: its priority table is computed by the build step
/// ([`crate::build`]) and kept by the [`crate::Rig`].
#[derive(Clone, Debug)]
pub struct Clip {
    name: String,
    duration: f32,
    pub(crate) groups: Vec<Vec<f32>>,
    pub(crate) translations: Vec<Block<Vec3A>>,
    pub(crate) rotations: Vec<Block<Quat>>,
    pub(crate) scales: Vec<Block<Vec3A>>,
    pub(crate) base_pose: Vec<Transform>,
    pub(crate) base_locals: Vec<Affine3A>,
    /// Bones with at least one animated channel, ascending (parents first).
    pub(crate) animated: Vec<u32>,
    /// The animated bones whose rotation is not in a lane block (constant or not linear): the
    /// ones [`Clip::sample_compose`] composes after the lane blocks, ascending.
    pub(crate) compose_rest: Vec<u32>,
    /// Per animated-bone slot: its translation, rotation and scale channels.
    pub(crate) slot_channels: Vec<[ChannelRef; 3]>,
    /// Bones that are animated or have an animated ancestor: the ones whose model matrix changes
    /// at full detail (ascending, so parents first).
    pub(crate) moving: Vec<u32>,
    /// Per animated-bone slot: the slot of its nearest animated ancestor (`u32::MAX`: none).
    /// The error bound sums the drift of held bones down each chain.
    pub(crate) ancestor_slot: Vec<u32>,
    stats: ChannelStats,
    source: Vec<ChannelDesc>,
    options: ClipOptions,
}

/// Composes the local matrices of `bones` from the scratch, four at a time.
#[inline]
fn compose_bones(bones: &[u32], s: &TrsScratch, locals: &mut [Affine3A]) {
    let mut fours = bones.chunks_exact(4);
    for b in &mut fours {
        let b = [b[0] as usize, b[1] as usize, b[2] as usize, b[3] as usize];
        let m = compose4(b.map(|b| s.s[b]), b.map(|b| s.r[b]), b.map(|b| s.t[b]));
        for (&b, m) in b.iter().zip(m) {
            locals[b] = m;
        }
    }
    for &b in fours.remainder() {
        let b = b as usize;
        locals[b] = compose(s.s[b], s.r[b], s.t[b]);
    }
}

fn bad_times(times: &[f32]) -> bool {
    times.iter().any(|t| !t.is_finite()) || times.windows(2).any(|w| w[1] < w[0])
}

/// Puts consecutive rotation keys in one hemisphere; returns the number of flips.
fn align_rotations(values: &mut [Quat], cubic: bool) -> u32 {
    let mut flips = 0;
    if cubic {
        let keys = values.len() / 3;
        for k in 1..keys {
            if values[3 * (k - 1) + 1].dot(values[3 * k + 1]) < 0.0 {
                flips += 1;
                for j in 0..3 {
                    values[3 * k + j] = -values[3 * k + j];
                }
            }
        }
    } else {
        for k in 1..values.len() {
            if values[k - 1].dot(values[k]) < 0.0 {
                flips += 1;
                values[k] = -values[k];
            }
        }
    }
    flips
}

fn is_constant<T: Copy>(
    values: &[T],
    cubic: bool,
    tol: f32,
    diff: impl Fn(T, T) -> f32,
    zero: T,
) -> bool {
    if tol < 0.0 {
        return values.len() <= if cubic { 3 } else { 1 };
    }
    if cubic {
        let first = values[1];
        values
            .chunks_exact(3)
            .all(|k| diff(k[1], first) <= tol && diff(k[0], zero) <= tol && diff(k[2], zero) <= tol)
    } else {
        let first = values[0];
        values.iter().all(|&v| diff(v, first) <= tol)
    }
}

fn group_of(groups: &mut Vec<Vec<f32>>, times: &[f32]) -> u32 {
    let same = |g: &Vec<f32>| {
        g.len() == times.len() && g.iter().zip(times).all(|(a, b)| a.to_bits() == b.to_bits())
    };
    match groups.iter().position(same) {
        Some(i) => i as u32,
        None => {
            groups.push(times.to_vec());
            (groups.len() - 1) as u32
        }
    }
}

fn push_channel<T: Copy>(
    blocks: &mut Vec<Block<T>>,
    group: u32,
    interpolation: Interpolation,
    bone: u32,
    values: Vec<T>,
) {
    // Channels are gathered per block as columns first and transposed once at the end.
    if let Some(b) = blocks
        .iter_mut()
        .find(|b| b.group == group && b.interpolation == interpolation)
    {
        b.bones.push(bone);
        b.keys.extend(values);
    } else {
        blocks.push(Block {
            group,
            interpolation,
            bones: vec![bone],
            keys: values,
            lanes: Vec::new(),
        });
    }
}

/// Turns channel-major storage (`keys[c * rows + r]`) into key-major (`keys[r * channels + c]`).
fn transpose<T: Copy>(block: &mut Block<T>) {
    let c = block.bones.len();
    let rows = block.keys.len() / c;
    let mut out = Vec::with_capacity(block.keys.len());
    for r in 0..rows {
        for ch in 0..c {
            out.push(block.keys[ch * rows + r]);
        }
    }
    block.keys = out;
}

impl Clip {
    /// Builds a clip for `skeleton` from its channels: validates them (known bones, one channel per
    /// property and bone, finite non-decreasing times, matching value counts, finite values),
    /// folds constant channels into the base pose and aligns rotation hemispheres. The duration is the last key time of any channel.
    pub fn new(
        name: impl Into<String>,
        skeleton: &Skeleton,
        channels: Vec<ChannelDesc>,
        options: &ClipOptions,
    ) -> Result<Clip, BuildError> {
        let n = skeleton.len();
        let mut seen = vec![[false; 3]; n];
        let mut base_pose = skeleton.rest_pose().to_vec();
        let mut stats = ChannelStats::default();
        let mut groups = Vec::new();
        let mut translations = Vec::new();
        let mut rotations = Vec::new();
        let mut scales = Vec::new();
        let mut duration = 0.0f32;
        let mut animated_mask = vec![0u8; n];
        let tol = options.constant_tolerance;
        let source = channels.clone();
        for ch in channels {
            let bone = ch.bone;
            if bone.index() >= n {
                return Err(BuildError::UnknownBone { bone, bones: n });
            }
            let prop = ch.keys.property();
            if std::mem::replace(&mut seen[bone.index()][prop.slot()], true) {
                return Err(BuildError::DuplicateChannel {
                    bone,
                    property: prop.name(),
                });
            }
            if ch.times.is_empty() {
                return Err(BuildError::NoKeys { bone });
            }
            if bad_times(&ch.times) {
                return Err(BuildError::BadKeyTimes { bone });
            }
            let cubic = ch.interpolation == Interpolation::CubicSpline;
            let expected = ch.times.len() * if cubic { 3 } else { 1 };
            if ch.keys.len() != expected {
                return Err(BuildError::KeyCountMismatch {
                    bone,
                    times: ch.times.len(),
                    values: ch.keys.len(),
                    expected,
                });
            }
            duration = duration.max(*ch.times.last().unwrap_or(&0.0));
            stats.keyed[prop.slot()] += 1;
            let non_finite = || BuildError::NonFinite {
                what: format!("{} keys of {bone}", prop.name()),
            };
            let value_index = |k: usize| if cubic { 3 * k + 1 } else { k };
            match ch.keys {
                Keys::Translation(v) | Keys::Scale(v) => {
                    if v.iter().any(|x| !x.is_finite()) {
                        return Err(non_finite());
                    }
                    let v: Vec<Vec3A> = v.into_iter().map(Vec3A::from).collect();
                    let diff = |a: Vec3A, b: Vec3A| (a - b).abs().max_element();
                    let tol = if tol < 0.0 {
                        tol
                    } else if prop == Property::Translation {
                        options.translation_tolerance
                    } else {
                        tol
                    };
                    if is_constant(&v, cubic, tol, diff, Vec3A::ZERO) {
                        stats.constant[prop.slot()] += 1;
                        let value: Vec3 = v[value_index(0)].into();
                        if prop == Property::Translation {
                            base_pose[bone.index()].translation = value;
                        } else {
                            base_pose[bone.index()].scale = value;
                        }
                    } else {
                        animated_mask[bone.index()] = 1;
                        let g = group_of(&mut groups, &ch.times);
                        let blocks = if prop == Property::Translation {
                            &mut translations
                        } else {
                            &mut scales
                        };
                        push_channel(blocks, g, ch.interpolation, bone.raw(), v);
                    }
                }
                Keys::Rotation(mut v) => {
                    if v.iter().any(|q| !q.is_finite()) {
                        return Err(non_finite());
                    }
                    for (k, q) in v.iter_mut().enumerate() {
                        let is_value = !cubic || k % 3 == 1;
                        let len = q.length();
                        if is_value {
                            if len < 1e-6 {
                                return Err(non_finite());
                            }
                            *q = Quat::from_vec4(Vec4::from(*q) / len);
                        }
                    }
                    for q in v.iter_mut() {
                        let x = Vec4::from(*q);
                        *q = Quat::from_vec4(Vec4::select(
                            x.abs().cmplt(Vec4::splat(1e-9)),
                            Vec4::ZERO,
                            x,
                        ));
                    }
                    stats.hemisphere_flips += align_rotations(&mut v, cubic);
                    let diff =
                        |a: Quat, b: Quat| (Vec4::from(a) - Vec4::from(b)).abs().max_element();
                    if is_constant(&v, cubic, tol, diff, Quat::from_xyzw(0.0, 0.0, 0.0, 0.0)) {
                        stats.constant[1] += 1;
                        base_pose[bone.index()].rotation = v[value_index(0)];
                    } else {
                        animated_mask[bone.index()] = 1;
                        let g = group_of(&mut groups, &ch.times);
                        push_channel(&mut rotations, g, ch.interpolation, bone.raw(), v);
                    }
                }
            }
        }
        translations.iter_mut().for_each(transpose);
        rotations.iter_mut().for_each(transpose);
        rotations.iter_mut().for_each(Block::build_lanes);
        scales.iter_mut().for_each(transpose);
        let base_locals = base_pose.iter().map(Transform::to_affine).collect();
        let animated: Vec<u32> = (0..n as u32)
            .filter(|&b| animated_mask[b as usize] != 0)
            .collect();
        let mut moves = animated_mask.clone();
        for b in 0..n {
            if let Some(p) = skeleton.parent(BoneId::new(b)) {
                moves[b] |= moves[p.index()];
            }
        }
        let moving = (0..n as u32).filter(|&b| moves[b as usize] != 0).collect();
        let animated: Vec<u32> = animated;
        let mut slot_of = vec![u32::MAX; n];
        for (i, &b) in animated.iter().enumerate() {
            slot_of[b as usize] = i as u32;
        }
        let ancestor_slot = animated
            .iter()
            .map(|&b| {
                let mut p = skeleton.parent(BoneId::from_raw(b));
                while let Some(q) = p {
                    if slot_of[q.index()] != u32::MAX {
                        return slot_of[q.index()];
                    }
                    p = skeleton.parent(q);
                }
                u32::MAX
            })
            .collect();
        let mut in_lanes = vec![false; n];
        for b in rotations.iter().filter(|b| !b.lanes.is_empty()) {
            b.bones.iter().for_each(|&b| in_lanes[b as usize] = true);
        }
        let compose_rest = animated
            .iter()
            .copied()
            .filter(|&b| !in_lanes[b as usize])
            .collect();
        let mut slot_channels = vec![[ChannelRef::NONE; 3]; animated.len()];
        let mut refs = |p: usize, blocks: &mut dyn Iterator<Item = &Vec<u32>>| {
            for (bi, bones) in blocks.enumerate() {
                for (col, &b) in bones.iter().enumerate() {
                    slot_channels[slot_of[b as usize] as usize][p] = ChannelRef {
                        block: bi as u32,
                        col: col as u32,
                    };
                }
            }
        };
        refs(0, &mut translations.iter().map(|b| &b.bones));
        refs(1, &mut rotations.iter().map(|b| &b.bones));
        refs(2, &mut scales.iter().map(|b| &b.bones));
        Ok(Clip {
            name: name.into(),
            duration,
            groups,
            translations,
            rotations,
            scales,
            base_pose,
            base_locals,
            animated,
            compose_rest,
            slot_channels,
            moving,
            ancestor_slot,
            stats,
            source,
            options: *options,
        })
    }

    /// Name (the glTF animation name, or `animation<i>`).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Length in seconds (0 for a single-key pose); playback loops over `[0, duration]`.
    pub fn duration(&self) -> f32 {
        self.duration
    }

    /// The channels the clip was built from, as given (before constant folding and hemisphere
    /// alignment).
    pub fn channels(&self) -> &[ChannelDesc] {
        &self.source
    }

    /// The options the clip was built with.
    pub fn options(&self) -> &ClipOptions {
        &self.options
    }

    /// Keyed and constant channel counts.
    pub fn stats(&self) -> &ChannelStats {
        &self.stats
    }

    /// Bones with at least one animated (non-constant) channel, parents first.
    pub fn animated_bones(&self) -> impl ExactSizeIterator<Item = BoneId> + '_ {
        self.animated.iter().map(|&b| BoneId::from_raw(b))
    }

    /// Number of bones with at least one animated channel.
    pub fn animated_bone_count(&self) -> usize {
        self.animated.len()
    }

    /// The local pose used for everything the clip does not animate: the rest pose with the
    /// clip's constant channels applied.
    pub(crate) fn base_pose(&self) -> &[Transform] {
        &self.base_pose
    }

    /// Wraps a playback time into `[0, duration)` (or 0 for a zero-length clip).
    #[inline]
    pub(crate) fn wrap_time(&self, t: f32) -> f32 {
        if self.duration > 0.0 {
            // The common case (a frame step past the end) without a call to fmod.
            if (0.0..self.duration).contains(&t) {
                return t;
            }
            if t >= self.duration && t < 2.0 * self.duration {
                return t - self.duration;
            }
            let w = t.rem_euclid(self.duration);
            if w < self.duration { w } else { 0.0 }
        } else {
            0.0
        }
    }

    /// One cursor per key-time group for playback time `t`.
    #[inline]
    pub(crate) fn locate_all(&self, t: f32, cursors: &mut Vec<Cursor>) {
        cursors.clear();
        cursors.extend(self.groups.iter().map(|g| locate(g, t)));
    }

    /// Samples every animated channel into the scratch.
    #[inline]
    pub(crate) fn sample(&self, cursors: &[Cursor], s: &mut TrsScratch) {
        for b in &self.translations {
            b.sample(cursors[b.group as usize], &mut s.t);
        }
        for b in &self.rotations {
            b.sample_rotations(cursors[b.group as usize], &mut s.r);
        }
        for b in &self.scales {
            b.sample(cursors[b.group as usize], &mut s.s);
        }
    }

    /// Samples every animated channel and composes the local matrix of every animated bone: the
    /// full-detail path. Rotations of linear blocks are composed straight from their lanes (and
    /// not stored in the scratch); the other animated bones from the scratch, four at a time.
    #[inline]
    pub(crate) fn sample_compose(
        &self,
        cursors: &[Cursor],
        s: &mut TrsScratch,
        locals: &mut [Affine3A],
    ) {
        for b in &self.translations {
            b.sample(cursors[b.group as usize], &mut s.t);
        }
        for b in &self.scales {
            b.sample(cursors[b.group as usize], &mut s.s);
        }
        for b in &self.rotations {
            let cur = cursors[b.group as usize];
            if b.lanes.is_empty() {
                b.sample(cur, &mut s.r);
            } else {
                b.sample_compose(cur, &s.t, &s.s, &mut s.lane_rotations, locals);
            }
        }
        compose_bones(&self.compose_rest, s, locals);
    }

    /// Samples and composes only the animated-bone slots listed in `slots`: the cost of a partial
    /// update is proportional to the bones that interpolate, not to all animated bones. Two
    /// passes (sample every listed channel, then compose every listed bone), like the block path,
    /// so that the long interpolate-normalise-compose chains of different bones overlap.
    #[inline]
    pub(crate) fn sample_slots(
        &self,
        cursors: &[Cursor],
        slots: &[u32],
        s: &mut TrsScratch,
        locals: &mut [Affine3A],
    ) {
        for &i in slots {
            let refs = &self.slot_channels[i as usize];
            let b = self.animated[i as usize] as usize;
            let r = refs[1];
            if r.block != u32::MAX {
                let blk = &self.rotations[r.block as usize];
                s.r[b] = blk.sample_one(r.col as usize, cursors[blk.group as usize]);
            }
        }
        for &i in slots {
            let refs = &self.slot_channels[i as usize];
            let b = self.animated[i as usize] as usize;
            let (t, sc) = (refs[0], refs[2]);
            if t.block != u32::MAX {
                let blk = &self.translations[t.block as usize];
                s.t[b] = blk.sample_one(t.col as usize, cursors[blk.group as usize]);
            }
            if sc.block != u32::MAX {
                let blk = &self.scales[sc.block as usize];
                s.s[b] = blk.sample_one(sc.col as usize, cursors[blk.group as usize]);
            }
        }
        for &i in slots {
            let b = self.animated[i as usize] as usize;
            locals[b] = compose(s.s[b], s.r[b], s.t[b]);
        }
    }

    /// Full local pose at time `t` (not wrapped), as matrices for every bone. Allocation-free
    /// apart from growing `cursors`; for reference evaluation and analysis.
    pub(crate) fn sample_locals(
        &self,
        t: f32,
        cursors: &mut Vec<Cursor>,
        s: &mut TrsScratch,
        out: &mut [Affine3A],
    ) {
        s.prepare(&self.base_pose);
        self.locate_all(t, cursors);
        out.copy_from_slice(&self.base_locals);
        self.sample_compose(cursors, s, out);
    }

    /// The local pose (translation, rotation, scale of every bone) at time `t` (not wrapped).
    pub(crate) fn sample_pose(&self, t: f32) -> Vec<Transform> {
        let mut s = TrsScratch::default();
        let mut cursors = Vec::new();
        s.prepare(&self.base_pose);
        self.locate_all(t, &mut cursors);
        self.sample(&cursors, &mut s);
        (0..self.base_pose.len())
            .map(|b| Transform {
                translation: s.t[b].into(),
                rotation: s.r[b],
                scale: s.s[b].into(),
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::BoneDesc;
    use crate::transform::rotation_angle;
    use glam::Mat4;

    pub(crate) fn chain(n: usize) -> Skeleton {
        Skeleton::new(
            (0..n)
                .map(|i| BoneDesc {
                    name: format!("b{i}"),
                    parent: (i > 0).then(|| BoneId::new(i - 1)),
                    rest: Transform {
                        translation: Vec3::new(0.0, 1.0, 0.0),
                        ..Transform::IDENTITY
                    },
                    inverse_bind: Mat4::IDENTITY,
                    is_joint: true,
                })
                .collect(),
        )
        .unwrap()
    }

    fn ch(bone: u32, interpolation: Interpolation, times: &[f32], keys: Keys) -> ChannelDesc {
        ChannelDesc {
            bone: BoneId::from_raw(bone),
            interpolation,
            times: times.to_vec(),
            keys,
        }
    }

    #[test]
    fn step_linear_cubic_values() {
        let sk = chain(3);
        let t = [0.0, 1.0, 2.0];
        let clip = Clip::new(
            "c",
            &sk,
            vec![
                ch(
                    0,
                    Interpolation::Step,
                    &t,
                    Keys::Translation(vec![Vec3::X, Vec3::Y, Vec3::Z]),
                ),
                ch(
                    1,
                    Interpolation::Linear,
                    &t,
                    Keys::Translation(vec![Vec3::ZERO, Vec3::X * 2.0, Vec3::ZERO]),
                ),
                // Cubic: value 0 → 1 with zero tangents: smoothstep.
                ch(
                    2,
                    Interpolation::CubicSpline,
                    &t[..2],
                    Keys::Scale(vec![
                        Vec3::ZERO,
                        Vec3::ONE,
                        Vec3::ZERO,
                        Vec3::ZERO,
                        Vec3::splat(2.0),
                        Vec3::ZERO,
                    ]),
                ),
            ],
            &ClipOptions::default(),
        )
        .unwrap();
        assert_eq!(clip.duration(), 2.0);
        let p = clip.sample_pose(0.5);
        assert_eq!(p[0].translation, Vec3::X);
        assert!((p[1].translation - Vec3::X).length() < 1e-6);
        assert!((p[2].scale - Vec3::splat(1.5)).length() < 1e-6);
        let p = clip.sample_pose(0.25);
        let smooth = 3.0 * 0.0625 - 2.0 * 0.015625;
        assert!((p[2].scale.x - (1.0 + smooth)).abs() < 1e-6);
        // Exactly on a key and past the end.
        assert_eq!(clip.sample_pose(1.0)[0].translation, Vec3::Y);
        assert_eq!(clip.sample_pose(5.0)[0].translation, Vec3::Z);
        assert_eq!(clip.sample_pose(-1.0)[0].translation, Vec3::X);
    }

    #[test]
    fn cubic_tangents_are_scaled_by_segment_length() {
        // p(s) = v0 h00 + Δ·b0 h10 + ...: with v0 = v1 = 0, b0 = 1, a1 = 0 and Δ = 2,
        // p(0.5) = 2 · (0.125 − 0.5 + 0.5) = 0.25.
        let sk = chain(1);
        let clip = Clip::new(
            "c",
            &sk,
            vec![ch(
                0,
                Interpolation::CubicSpline,
                &[0.0, 2.0],
                Keys::Translation(vec![
                    Vec3::ZERO,
                    Vec3::ZERO,
                    Vec3::X,
                    Vec3::ZERO,
                    Vec3::ZERO,
                    Vec3::ZERO,
                ]),
            )],
            &ClipOptions::default(),
        )
        .unwrap();
        assert!((clip.sample_pose(1.0)[0].translation.x - 0.25).abs() < 1e-6);
    }

    #[test]
    fn q_minus_q_keys_are_no_motion() {
        let sk = chain(1);
        let q = Quat::from_rotation_y(1.0);
        let clip = Clip::new(
            "c",
            &sk,
            vec![ch(
                0,
                Interpolation::Linear,
                &[0.0, 1.0, 2.0],
                Keys::Rotation(vec![q, -q, q]),
            )],
            &ClipOptions::default(),
        )
        .unwrap();
        // Same rotation written with both signs: constant, never sampled.
        assert_eq!(clip.stats().constant(Property::Rotation), 1);
        assert_eq!(clip.stats().hemisphere_flips, 1);
        assert_eq!(clip.animated_bone_count(), 0);
        // With detection off it is sampled, and still never leaves q (no flip through identity).
        let off = ClipOptions::SAMPLE_ALL;
        let clip = Clip::new(
            "c",
            &sk,
            vec![ch(
                0,
                Interpolation::Linear,
                &[0.0, 1.0, 2.0],
                Keys::Rotation(vec![q, -q, q]),
            )],
            &off,
        )
        .unwrap();
        assert_eq!(clip.animated_bone_count(), 1);
        for i in 0..=20 {
            let r = clip.sample_pose(i as f32 * 0.1)[0].rotation;
            assert!(rotation_angle(r, q) < 1e-5);
        }
        // A real motion across the sign boundary takes the short arc: 0.2 rad, not 2π − 0.2.
        let a = Quat::from_rotation_z(3.1);
        let b = -Quat::from_rotation_z(3.3);
        let clip = Clip::new(
            "c",
            &sk,
            vec![ch(
                0,
                Interpolation::Linear,
                &[0.0, 1.0],
                Keys::Rotation(vec![a, b]),
            )],
            &off,
        )
        .unwrap();
        let mid = clip.sample_pose(0.5)[0].rotation;
        assert!(rotation_angle(mid, Quat::from_rotation_z(3.2)) < 1e-4);
    }

    #[test]
    fn cubic_rotation_hemisphere_flips_tangents_too() {
        let sk = chain(1);
        let q = Quat::from_rotation_x(0.5);
        let z = Quat::from_xyzw(0.0, 0.0, 0.0, 0.0);
        let clip = Clip::new(
            "c",
            &sk,
            vec![ch(
                0,
                Interpolation::CubicSpline,
                &[0.0, 1.0],
                Keys::Rotation(vec![z, q, z, z, -q, z]),
            )],
            &ClipOptions::SAMPLE_ALL,
        )
        .unwrap();
        let mid = clip.sample_pose(0.5)[0].rotation;
        assert!(rotation_angle(mid, q) < 1e-5);
    }

    #[test]
    fn validation_errors() {
        let sk = chain(2);
        let o = ClipOptions::default();
        let lin = Interpolation::Linear;
        let e = Clip::new(
            "c",
            &sk,
            vec![ch(5, lin, &[0.0], Keys::Translation(vec![Vec3::ZERO]))],
            &o,
        );
        assert!(matches!(e, Err(BuildError::UnknownBone { .. })));
        let e = Clip::new(
            "c",
            &sk,
            vec![ch(
                0,
                lin,
                &[1.0, 0.0],
                Keys::Translation(vec![Vec3::ZERO; 2]),
            )],
            &o,
        );
        assert!(matches!(e, Err(BuildError::BadKeyTimes { .. })));
        let e = Clip::new(
            "c",
            &sk,
            vec![ch(
                0,
                lin,
                &[0.0, f32::NAN],
                Keys::Translation(vec![Vec3::ZERO; 2]),
            )],
            &o,
        );
        assert!(matches!(e, Err(BuildError::BadKeyTimes { .. })));
        let e = Clip::new(
            "c",
            &sk,
            vec![ch(
                0,
                lin,
                &[0.0, 1.0],
                Keys::Translation(vec![Vec3::ZERO; 3]),
            )],
            &o,
        );
        assert!(matches!(e, Err(BuildError::KeyCountMismatch { .. })));
        let e = Clip::new(
            "c",
            &sk,
            vec![ch(
                0,
                lin,
                &[0.0],
                Keys::Rotation(vec![Quat::from_xyzw(f32::NAN, 0.0, 0.0, 1.0)]),
            )],
            &o,
        );
        assert!(matches!(e, Err(BuildError::NonFinite { .. })));
        let e = Clip::new(
            "c",
            &sk,
            vec![
                ch(0, lin, &[0.0], Keys::Scale(vec![Vec3::ONE])),
                ch(0, lin, &[0.0], Keys::Scale(vec![Vec3::ONE])),
            ],
            &o,
        );
        assert!(matches!(e, Err(BuildError::DuplicateChannel { .. })));
        let e = Clip::new("c", &sk, vec![ch(0, lin, &[], Keys::Scale(vec![]))], &o);
        assert!(matches!(e, Err(BuildError::NoKeys { .. })));
    }

    #[test]
    fn sparse_sampling_matches_block_sampling() {
        // Mixed interpolations and key times; every subset of slots sampled one by one must give
        // the same local matrices as the block path.
        let sk = chain(4);
        let t3 = [0.0, 0.4, 1.0];
        let q = |a: f32| Quat::from_rotation_x(a);
        let clip = Clip::new(
            "c",
            &sk,
            vec![
                ch(
                    0,
                    Interpolation::Linear,
                    &t3,
                    Keys::Rotation(vec![q(0.0), q(0.5), q(0.2)]),
                ),
                ch(
                    1,
                    Interpolation::Step,
                    &t3,
                    Keys::Translation(vec![Vec3::X, Vec3::Y, Vec3::Z]),
                ),
                ch(
                    1,
                    Interpolation::Linear,
                    &[0.0, 2.0],
                    Keys::Scale(vec![Vec3::ONE, Vec3::splat(2.0)]),
                ),
                ch(
                    3,
                    Interpolation::CubicSpline,
                    &[0.0, 1.0],
                    Keys::Rotation(vec![q(0.0), q(0.1), q(0.3), q(0.2), q(0.9), q(0.0)]),
                ),
            ],
            &ClipOptions::default(),
        )
        .unwrap();
        let mut cursors = Vec::new();
        let mut s = TrsScratch::default();
        let mut full = vec![Affine3A::IDENTITY; 4];
        let slots = clip.animated_bone_count() as u32;
        for t in [0.0, 0.3, 0.4, 0.77, 1.5] {
            clip.sample_locals(t, &mut cursors, &mut s, &mut full);
            for subset in 0..(1u32 << slots) {
                let list: Vec<u32> = (0..slots).filter(|i| subset & (1 << i) != 0).collect();
                let mut sparse = clip.base_locals.clone();
                s.prepare(&clip.base_pose);
                clip.sample_slots(&cursors, &list, &mut s, &mut sparse);
                for &i in &list {
                    let b = clip.animated[i as usize] as usize;
                    assert!(sparse[b].abs_diff_eq(full[b], 1e-6), "t {t} bone {b}");
                }
            }
        }
    }

    #[test]
    fn shared_times_share_a_block() {
        let sk = chain(3);
        let t = [0.0, 0.5, 1.0];
        let rot = |a: f32| {
            Keys::Rotation(vec![
                Quat::IDENTITY,
                Quat::from_rotation_x(a),
                Quat::IDENTITY,
            ])
        };
        let clip = Clip::new(
            "c",
            &sk,
            vec![
                ch(0, Interpolation::Linear, &t, rot(0.1)),
                ch(1, Interpolation::Linear, &t, rot(0.2)),
                ch(
                    2,
                    Interpolation::Linear,
                    &[0.0, 1.0],
                    Keys::Rotation(vec![Quat::IDENTITY, Quat::from_rotation_x(0.3)]),
                ),
            ],
            &ClipOptions::default(),
        )
        .unwrap();
        assert_eq!(clip.groups.len(), 2);
        assert_eq!(clip.rotations.len(), 2);
        assert_eq!(clip.rotations[0].bones, vec![0, 1]);
        let p = clip.sample_pose(0.25);
        assert!((rotation_angle(p[1].rotation, Quat::IDENTITY) - 0.1).abs() < 1e-4);
        assert!((rotation_angle(p[2].rotation, Quat::IDENTITY) - 0.075).abs() < 1e-4);
    }
}
#[cfg(test)]
mod lane_tests {
    use super::*;

    /// The lane paths (four rotations interpolated at once, four bones composed at once) give the
    /// poses of the per-channel, per-bone path within 1e-5 on every clip of the bundled rigs, with
    /// and without constant-channel folding.
    #[test]
    fn lane_sampling_matches_per_channel_sampling() {
        let dir = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../assets/gltf");
        let mut files: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| matches!(p.extension().and_then(|e| e.to_str()), Some("glb" | "gltf")))
            .collect();
        files.sort();
        assert!(files.len() >= 5, "{files:?}");
        let (mut lane_blocks, mut clips) = (0, 0);
        for file in &files {
            for clip_options in [ClipOptions::default(), ClipOptions::SAMPLE_ALL] {
                let options = crate::ImportOptions { clip: clip_options };
                let rig = crate::build::import_path_with(file, &options).unwrap();
                let n = rig.bone_count();
                for clip in rig.clips() {
                    clips += 1;
                    lane_blocks += clip
                        .rotations
                        .iter()
                        .filter(|b| !b.lanes.is_empty())
                        .count();
                    let (mut cursors, mut s, mut fast) = (
                        Vec::new(),
                        TrsScratch::default(),
                        vec![Affine3A::IDENTITY; n],
                    );
                    let (mut r, mut q) = (TrsScratch::default(), TrsScratch::default());
                    let mut slow = vec![Affine3A::IDENTITY; n];
                    let d = clip.duration();
                    for i in 0..=64 {
                        let t = -0.05 + (d + 0.1) * i as f32 / 64.0;
                        clip.sample_locals(t, &mut cursors, &mut s, &mut fast);
                        r.prepare(clip.base_pose());
                        for b in &clip.translations {
                            b.sample(cursors[b.group as usize], &mut r.t);
                        }
                        for b in &clip.rotations {
                            b.sample(cursors[b.group as usize], &mut r.r);
                        }
                        for b in &clip.scales {
                            b.sample(cursors[b.group as usize], &mut r.s);
                        }
                        q.prepare(clip.base_pose());
                        clip.sample(&cursors, &mut q);
                        slow.copy_from_slice(&clip.base_locals);
                        for &b in &clip.animated {
                            let b = b as usize;
                            slow[b] = compose(r.s[b], r.r[b], r.t[b]);
                        }
                        for b in 0..n {
                            let what = format!("{file:?} {} t={t} bone {b}", clip.name());
                            assert!(
                                Vec4::from(q.r[b]).abs_diff_eq(Vec4::from(r.r[b]), 1e-5),
                                "{what}: {:?} vs {:?}",
                                q.r[b],
                                r.r[b]
                            );
                            assert!(fast[b].abs_diff_eq(slow[b], 1e-5), "{what}");
                        }
                    }
                }
            }
        }
        assert!(lane_blocks > 0 && clips > 10, "{lane_blocks} {clips}");
    }
}
