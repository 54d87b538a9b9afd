//! Quality presets for people: [`DdgiQuality`] sets the fields of a [`DdgiVolume`] that trade light
//! quality against GPU time (rays per probe, the maps' resolution, the adaptive budgets' fewest
//! rays), in the manner of Bevy's `ScreenSpaceAmbientOcclusionQualityLevel`. Every other field keeps its
//! value, and experts set any field directly ([`DdgiQuality::Custom`]). What each preset costs on
//! a given GPU is measured in BENCHMARKS.md, not stated here.

use crate::volume::DdgiVolume;

/// How much GPU time a volume spends on its light. The presets differ only in the fields
/// [`DdgiQuality::apply`] lists; the grid, the bounds and every weight stay as set.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DdgiQuality {
    /// Half the rays of `Medium` and a lower floor for the adaptive budgets: noisier and slower to
    /// settle after a change, for integrated GPUs and large grids. The trace and shading cost
    /// about half of `Medium`'s; the maps (8×8 irradiance, 16×16 distance) are `Medium`'s.
    Low,
    /// The defaults ([`DdgiVolume::default`]): 128 rays a probe, 8×8 irradiance and 16×16
    /// distance maps.
    #[default]
    Medium,
    /// Twice the rays of `Medium` and a higher floor for the adaptive budgets: less noise and
    /// faster recovery after a change, for the same maps. The trace and shading cost up to twice
    /// `Medium`'s (adaptive budgets rest calm probes, so a static scene pays less).
    High,
    /// The volume's fields as they are: nothing is changed.
    Custom,
}

/// The fields each preset sets: rays per probe, irradiance and distance texels, the adaptive
/// budgets' fewest rays (one row per preset, in the order of the variants; `Custom` has none).
const PRESETS: [(DdgiQuality, u32, u32, u32, u32); 3] =
    [(DdgiQuality::Low, 64, 8, 16, 8), (DdgiQuality::Medium, 128, 8, 16, 16), (DdgiQuality::High, 256, 8, 16, 32)];

impl DdgiQuality {
    /// `volume` with this preset's rays per probe, map resolutions and adaptive ray floor; every
    /// other field (grid, bounds, weights, hysteresis, …) as it was. `Custom` returns it unchanged.
    pub fn apply(self, volume: DdgiVolume) -> DdgiVolume {
        let Some(&(_, rays, irradiance, distance, min_rays)) = PRESETS.iter().find(|p| p.0 == self) else {
            return volume;
        };
        let mut volume = DdgiVolume { rays_per_probe: rays, irradiance_texels: irradiance, distance_texels: distance, ..volume };
        volume.adaptive.min_rays = min_rays;
        volume
    }

    /// A default volume at this preset.
    pub fn volume(self) -> DdgiVolume {
        self.apply(DdgiVolume::default())
    }

    /// The preset whose fields `volume` has, or `Custom` when it matches none.
    pub fn of(volume: &DdgiVolume) -> DdgiQuality {
        PRESETS
            .iter()
            .find(|&&(_, rays, irradiance, distance, min_rays)| {
                (volume.rays_per_probe, volume.irradiance_texels, volume.distance_texels, volume.adaptive.min_rays)
                    == (rays, irradiance, distance, min_rays)
            })
            .map_or(DdgiQuality::Custom, |p| p.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn medium_is_the_default_and_the_presets_order_their_cost() {
        assert_eq!(DdgiQuality::Medium.volume(), DdgiVolume::default());
        assert_eq!(DdgiQuality::of(&DdgiVolume::default()), DdgiQuality::Medium);
        let [low, medium, high] = [DdgiQuality::Low, DdgiQuality::Medium, DdgiQuality::High].map(DdgiQuality::volume);
        assert!(low.rays_per_probe < medium.rays_per_probe && medium.rays_per_probe < high.rays_per_probe);
        assert!(low.adaptive.min_rays < medium.adaptive.min_rays && medium.adaptive.min_rays < high.adaptive.min_rays);
        for (quality, volume) in [(DdgiQuality::Low, &low), (DdgiQuality::Medium, &medium), (DdgiQuality::High, &high)] {
            volume.validate().unwrap_or_else(|e| panic!("{quality:?}: {e}"));
            assert_eq!(DdgiQuality::of(volume), quality);
            assert!(volume.adaptive.min_rays <= volume.rays_per_probe);
        }
    }

    #[test]
    fn a_preset_keeps_every_other_field_and_custom_changes_nothing() {
        let mine = DdgiVolume { probe_counts: Some(glam::UVec3::new(4, 2, 4)), hysteresis: 0.9, rays_per_probe: 200, ..Default::default() };
        let low = DdgiQuality::Low.apply(mine.clone());
        assert_eq!((low.probe_counts, low.hysteresis, low.rays_per_probe), (mine.probe_counts, 0.9, 64));
        assert_eq!(DdgiQuality::Custom.apply(mine.clone()), mine);
        assert_eq!(DdgiQuality::of(&mine), DdgiQuality::Custom);
    }
}
