//! Choosing one token from a distribution: greedy, or sampled with temperature, top-k and
//! top-p (nucleus), seeded.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use token_constraint::TokenId;

/// Sampling settings (the paper's "recommended sampling" rows, Table 6).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SamplingConfig {
    /// 0 is greedy.
    pub temperature: f64,
    /// Keep the smallest set of most likely tokens whose mass reaches `top_p` (1 keeps all).
    pub top_p: f64,
    /// Keep the `top_k` most likely tokens (`None`: no cut-off).
    pub top_k: Option<usize>,
    /// Seed of the sampler's random stream: the same seed and distributions, the same tokens.
    pub seed: u64,
}

impl Default for SamplingConfig {
    /// Qwen's recommended sampling for thinking mode: temperature 1.0, top-p 0.95, top-k 20.
    fn default() -> Self {
        SamplingConfig { temperature: 1.0, top_p: 0.95, top_k: Some(20), seed: 0 }
    }
}

/// A seeded sampler. ChaCha8 keeps the stream identical across platforms and crate versions.
#[derive(Debug, Clone)]
pub struct Sampler {
    config: SamplingConfig,
    rng: ChaCha8Rng,
}

impl Sampler {
    /// A sampler seeded with `config.seed`.
    pub fn new(config: SamplingConfig) -> Sampler {
        let rng = ChaCha8Rng::seed_from_u64(config.seed);
        Sampler { config, rng }
    }

    /// One token from `candidates` (token, probability), sorted by decreasing probability.
    pub fn pick(&mut self, candidates: &[(TokenId, f32)]) -> Option<TokenId> {
        let first = candidates.first()?.0;
        if self.config.temperature <= 0.0 {
            return Some(first);
        }
        let kept = &candidates[..self.config.top_k.unwrap_or(usize::MAX).clamp(1, candidates.len())];
        let inverse = 1.0 / self.config.temperature;
        let weights: Vec<f64> = kept.iter().map(|&(_, p)| f64::from(p).max(0.0).powf(inverse)).collect();
        let total: f64 = weights.iter().sum();
        if total.is_nan() || total <= 0.0 {
            return Some(first);
        }
        let mut nucleus = 0;
        let mut mass = 0.0;
        while nucleus < weights.len() {
            mass += weights[nucleus] / total;
            nucleus += 1;
            if mass >= self.config.top_p {
                break;
            }
        }
        let nucleus_total: f64 = weights[..nucleus].iter().sum();
        let mut draw = self.rng.random::<f64>() * nucleus_total;
        for (i, w) in weights[..nucleus].iter().enumerate() {
            if draw < *w {
                return Some(kept[i].0);
            }
            draw -= w;
        }
        Some(kept[nucleus - 1].0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn greedy_and_cut_offs() {
        let c = [(5, 0.5f32), (2, 0.3), (9, 0.2)];
        let mut greedy = Sampler::new(SamplingConfig { temperature: 0.0, ..SamplingConfig::default() });
        assert_eq!(greedy.pick(&c), Some(5));
        let mut top1 = Sampler::new(SamplingConfig { top_k: Some(1), ..SamplingConfig::default() });
        assert!((0..50).all(|_| top1.pick(&c) == Some(5)));
        let mut nucleus = Sampler::new(SamplingConfig { top_p: 0.75, top_k: None, ..SamplingConfig::default() });
        let picks: Vec<_> = (0..300).map(|_| nucleus.pick(&c).unwrap()).collect();
        assert!(picks.contains(&5) && picks.contains(&2) && !picks.contains(&9));
        assert_eq!(Sampler::new(SamplingConfig::default()).pick(&[]), None);
    }

    #[test]
    fn same_seed_same_stream() {
        let c: Vec<(u32, f32)> = (0..10).map(|i| (i, 0.1)).collect();
        let config = SamplingConfig { seed: 42, top_k: None, top_p: 1.0, temperature: 1.0 };
        let a: Vec<_> = {
            let mut s = Sampler::new(config.clone());
            (0..100).map(|_| s.pick(&c)).collect()
        };
        let mut s = Sampler::new(config);
        let b: Vec<_> = (0..100).map(|_| s.pick(&c)).collect();
        assert_eq!(a, b);
        assert!(a.iter().collect::<rustc_hash::FxHashSet<_>>().len() > 5);
    }
}
