//! `experiments list`: every pluggable component linked into this binary, with an example TOML
//! block to paste into an experiment file.

use fieldprobe_core::registry::components;

pub fn run() {
    let mut last = None;
    for c in components() {
        if last != Some(c.kind) {
            println!("## {:?} — `[{}]`\n", c.kind, c.kind.table());
            last = Some(c.kind);
        }
        println!("### `{}` ({})\n{}\n", c.name, c.provider, c.summary);
        println!("```toml\n[{}]\n{}\n```\n", c.kind.table(), c.example);
    }
}
