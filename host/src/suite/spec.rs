//! What to generate: the options of a suite, one [`Spec`] per problem, each problem's stream
//! of seeds, and how many samples a seed gets.

use omcbsa_core::rng::Rng;

use super::family::Family;
use super::layout::LayoutKind;
use super::standing::Stance;
use super::trap::Tightness;

/// Samples of a task family tried from one seed.
pub const TASK_SAMPLES: u64 = 10;
/// Samples with a witness tried before one that IK tracking solves is kept.
pub const HARD_SAMPLES: usize = 10;
/// Samples of the random and approach families tried from one seed.
pub(super) const RANDOM_SAMPLES: u64 = 64;
/// Samples of the mixed family (random motions of Gen3s and Pandas) tried from one seed: a
/// Panda finds a clear random motion in a crowded layout about a third as often as a Gen3.
pub(super) const MIXED_SAMPLES: u64 = 256;
/// Seeds a problem is drawn from before it is left out.
pub const MAX_DRAWS: u32 = 16;

/// How `omcbsa gen-bench` generates the suite.
#[derive(Clone, Debug, PartialEq)]
pub struct GenOptions {
    /// Seed of the whole suite.
    pub seed: u64,
    /// Problems per motion family, spread evenly over the family's layouts and arm counts.
    pub per_family: usize,
    /// The families generated (each with the problems it has in the whole suite).
    pub families: Vec<Family>,
}

impl Default for GenOptions {
    /// The published suite: 8 families x 76 = 608 problems.
    fn default() -> Self {
        GenOptions {
            seed: 20_250_606,
            per_family: 76,
            families: Family::ALL.to_vec(),
        }
    }
}

/// What to generate for one problem.
pub(super) struct Spec {
    pub name: String,
    pub family: Family,
    pub layout: LayoutKind,
    pub robots: usize,
    /// Seeds the stream of the problem's seeds.
    pub stream: u64,
    pub traps: Tightness,
    /// How the approach family's arms stand.
    pub stance: Option<Stance>,
}

pub(super) fn specs(opts: &GenOptions, traps: Tightness) -> Vec<Spec> {
    let mut specs = Vec::new();
    // Seeds come from a family's place in `Family::ALL`, so a subset is the same problems.
    let chosen = (Family::ALL.into_iter().enumerate()).filter(|(_, f)| opts.families.contains(f));
    for (f, family) in chosen {
        let cells = family.cells();
        for k in 0..opts.per_family {
            let (layout, robots) = cells[k % cells.len()];
            let stream = opts.seed ^ ((f as u64) << 32 | k as u64);
            let name = format!("{}_{}_{robots}arms_{k:03}", family.name(), layout.name());
            let stance = (family == Family::Approach).then(|| Stance::ALL[k % Stance::ALL.len()]);
            specs.push(Spec {
                name,
                family,
                layout,
                robots,
                stream,
                traps,
                stance,
            });
        }
    }
    specs
}

impl Spec {
    /// The problem's seeds, in the order it is drawn from them.
    pub(super) fn seeds(&self) -> impl Iterator<Item = u64> {
        let mut stream = Rng::new(self.stream);
        std::iter::repeat_with(move || stream.next_u64())
    }
}
