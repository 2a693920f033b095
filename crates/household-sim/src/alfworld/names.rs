//! The names TextWorld and ALFWorld give entities: `EntityInfo`s (name, indefinite article
//! "a", definite "the", id) renamed by ALFWorld's `Demangler(shuffle=False)`.
//!
//! The entities are the objects that occur in the problem's initial atoms. An id with
//! `_bar_` is spelled `<class> <n>`: the class is the id up to its first `_bar_` (plus
//! `basin` when the id contains `basin`), and within a class the ids in ascending order get
//! `n, n-1, ..., 1` (the smallest id is numbered highest). An id without `_bar_` keeps its
//! text (after the demangler's replacements) followed by one space, as the demangler spells
//! it (`"agent1 "`).

use rustc_hash::FxHashMap;

/// What the grammar's `{x.name}`, `{x.id}`, `{x.indefinite}` and `{x.definite}` read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct EntityInfo {
    pub id: String,
    pub name: String,
}

impl EntityInfo {
    pub(crate) fn indefinite(&self) -> &'static str {
        "a"
    }

    pub(crate) fn definite(&self) -> &'static str {
        "the"
    }
}

fn demangled_text(id: &str) -> String {
    id.replace("_bar_", "|").replace("_minus_", "-").replace("_plus_", "+").replace("_dot_", ".").replace("_comma_", ",")
}

/// Display names for `ids`, which must be sorted ascending (byte order, as Python sorts
/// ASCII strings) and distinct.
pub(crate) fn demangle(ids: &[&str]) -> Vec<String> {
    let class = |id: &str| -> Option<String> {
        let text = demangled_text(id);
        let (name, _) = text.split_once('|')?;
        Some(if id.contains("basin") { format!("{name}basin") } else { name.to_string() })
    };
    let mut remaining: FxHashMap<String, usize> = FxHashMap::default();
    for id in ids {
        if let Some(c) = class(id) {
            *remaining.entry(c).or_default() += 1;
        }
    }
    ids.iter()
        .map(|id| match class(id) {
            Some(c) => {
                let n = remaining.get_mut(&c).expect("counted above");
                let number = *n;
                *n -= 1;
                format!("{c} {number}")
            }
            None => format!("{} ", demangled_text(id)),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_run_down_in_id_order_and_basins_are_their_own_class() {
        let ids = ["agent1", "desk_bar__plus_01", "desk_bar__plus_02", "sink_bar_x_bar_sinkbasin", "sink_bar_y"];
        assert_eq!(demangle(&ids), ["agent1 ", "desk 2", "desk 1", "sinkbasin 1", "sink 1"]);
    }
}
