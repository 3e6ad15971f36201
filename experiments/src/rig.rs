//! Rigs built for the experiments from real ones: the thesis' 153-bone character
//! (`animation-lod-bone-priority-thesis.txt`, chapter 13) made by replicating a real skeleton
//! and its real motion.

use animlod::{BoneDesc, BoneId, BuildError, ChannelDesc, Clip, MAX_BONES, Rig, Skeleton};

/// A rig of exactly `bones` bones (at least the current count) made by replicating this one:
/// copies of every non-root bone, with their channels, hang under the same roots until the
/// count is reached (the last copy keeps a parents-first prefix). Copies join every skin their
/// original is in. The thesis' crowd test uses 153-bone characters; no real rig here has that
/// many, so this builds one from a real skeleton and real motion.
pub fn grown_to(rig: &Rig, bones: usize) -> Result<Rig, BuildError> {
    let n0 = rig.skeleton().len();
    if bones < n0 || bones > MAX_BONES {
        return Err(BuildError::TooManyBones(bones));
    }
    let base = rig.skeleton().descs();
    let non_roots: Vec<usize> = (0..n0).filter(|&i| base[i].parent.is_some()).collect();
    if non_roots.is_empty() && bones > n0 {
        return Err(BuildError::EmptySkeleton);
    }
    let mut descs = base.clone();
    let mut origin: Vec<usize> = (0..n0).collect();
    let mut copy = 0;
    while descs.len() < bones {
        copy += 1;
        let mut map = vec![usize::MAX; n0];
        for &i in &non_roots {
            if descs.len() == bones {
                break;
            }
            let p = base[i].parent.map(|p| p.index()).unwrap_or(0);
            let new_parent = if base[p].parent.is_none() { p } else { map[p] };
            map[i] = descs.len();
            origin.push(i);
            descs.push(BoneDesc {
                name: format!("{}#{copy}", base[i].name),
                parent: Some(BoneId::new(new_parent)),
                ..base[i].clone()
            });
        }
    }
    let skeleton = Skeleton::new(descs)?;
    let clips = rig
        .clips()
        .iter()
        .map(|c| {
            let mut channels: Vec<ChannelDesc> = c.channels().to_vec();
            for (new, &orig) in origin.iter().enumerate().skip(n0) {
                channels.extend(
                    c.channels()
                        .iter()
                        .filter(|ch| ch.bone.index() == orig)
                        .map(|ch| ChannelDesc {
                            bone: BoneId::new(new),
                            ..ch.clone()
                        }),
                );
            }
            Clip::new(c.name(), &skeleton, channels, c.options())
        })
        .collect::<Result<Vec<_>, _>>()?;
    let skins = rig
        .skins()
        .iter()
        .map(|s| {
            let mut s = s.clone();
            for (new, &orig) in origin.iter().enumerate().skip(n0) {
                if let Some(k) = s.joints.iter().position(|j| j.index() == orig) {
                    s.joints.push(BoneId::new(new));
                    s.inverse_bind.push(s.inverse_bind[k]);
                }
            }
            s
        })
        .collect();
    let mut grown = animlod::build::rig(skeleton, clips, skins)?;
    grown.set_import_report(*rig.import_report());
    Ok(grown)
}
