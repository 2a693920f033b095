//! Holm's step-down correction of one family of p-values (Appendix B: "Holm correction is
//! applied separately within each family"; Tables 9-10 print the adjusted p-values).

use super::StatsError;

/// Holm's adjusted p-values, in the order of `p_values`.
///
/// With the m raw p-values sorted ascending as p₍₁₎ ≤ … ≤ p₍ₘ₎, the adjusted value of p₍ᵢ₎ is
/// min(1, max_{j ≤ i} (m - j + 1) · p₍ⱼ₎): each is at least its raw value, at most 1, and
/// they never decrease along the raw order. Rejecting the hypotheses whose adjusted p-value is
/// at most α is Holm's procedure at family-wise error rate α. This is statsmodels'
/// `multipletests(p_values, method="holm")[1]`, with the same products, so the values agree
/// to the bit; tied raw values get equal adjusted values whatever their order.
///
/// Errors: an empty family ([`StatsError::TooFewValues`]); a value outside [0, 1] or NaN
/// ([`StatsError::InvalidPValue`]).
pub fn holm_adjust(p_values: &[f64]) -> Result<Vec<f64>, StatsError> {
    if p_values.is_empty() {
        return Err(StatsError::TooFewValues { what: "Holm correction", needed: 1, found: 0 });
    }
    if let Some((index, &value)) = p_values.iter().enumerate().find(|(_, p)| !(0.0..=1.0).contains(*p)) {
        return Err(StatsError::InvalidPValue { index, value });
    }
    let m = p_values.len();
    let mut order: Vec<usize> = (0..m).collect();
    order.sort_by(|&a, &b| p_values[a].total_cmp(&p_values[b]));
    let mut adjusted = vec![0.0; m];
    let mut running_max = 0.0_f64;
    for (rank, &index) in order.iter().enumerate() {
        running_max = running_max.max((m - rank) as f64 * p_values[index]);
        adjusted[index] = running_max.min(1.0);
    }
    Ok(adjusted)
}
