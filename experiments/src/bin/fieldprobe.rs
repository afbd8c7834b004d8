//! `fieldprobe`: the same command line as `experiments`, under the project's name (the package
//! stays `experiments`, so `cargo run -p experiments -- FILE.toml` keeps working).

fn main() -> anyhow::Result<()> {
    experiments::cli_main()
}
