//! `experiments list`: every pluggable component linked into this binary, with an example TOML
//! block to paste into an experiment file.

pub fn run() {
    print!("{}", fieldprobe::registry::catalogue());
}
