//! How TOML layers combine: an ablation variant over its base, `--set` overrides over either.
//!
//! * a table merges into the base's table key by key, recursively;
//! * a table whose `type` differs from the base table's `type` replaces it entirely (a component
//!   switch must not inherit the old component's fields; the new component's defaults apply);
//! * an empty table replaces the base's table (merged, it would change nothing, so it can only
//!   mean "none of these": `regularizers = {}` is the run without regularizers);
//! * anything else (numbers, strings, arrays) replaces the base's value.
//!
//! Hand-written (fifty lines over `toml::Table`) because the rules are the project's own; generic
//! layered-config crates (`figment`, `config`) merge tables key by key only.

use toml::{Table, Value};

/// Deep-merges `over` into `base` (see the module docs for the rules).
pub fn merge(base: &mut Table, over: &Table) {
    for (k, v) in over {
        match (base.get_mut(k), v) {
            (Some(Value::Table(b)), Value::Table(o)) if !o.is_empty() && !switches_type(b, o) => {
                merge(b, o)
            }
            _ => {
                base.insert(k.clone(), v.clone());
            }
        }
    }
}

/// Whether `over` names a component `type` other than `base`'s.
fn switches_type(base: &Table, over: &Table) -> bool {
    over.get("type")
        .is_some_and(|t| base.get("type") != Some(t))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_merge_key_by_key_and_a_new_type_or_an_empty_table_replaces() {
        let mut base: Table = toml::from_str(
            "a = 1\n[t]\nx = 1\ny = { p = 1, q = 2 }\n[c]\ntype = \"u\"\nk = 1\n[d]\ntype = \"u\"\nk = 1\nj = 2\n[e.one]\nk = 1",
        )
        .unwrap();
        let over: Table = toml::from_str(
            "a = 2\nnew = [1, 2]\nt = { y = { q = 3 } }\nc = { type = \"v\", m = 5 }\nd = { type = \"u\", k = 7 }\ne = {}",
        )
        .unwrap();
        merge(&mut base, &over);
        let want: Table = toml::from_str(
            "a = 2\nnew = [1, 2]\ne = {}\n[t]\nx = 1\ny = { p = 1, q = 3 }\n[c]\ntype = \"v\"\nm = 5\n[d]\ntype = \"u\"\nk = 7\nj = 2",
        )
        .unwrap();
        assert_eq!(base, want);
    }
}
