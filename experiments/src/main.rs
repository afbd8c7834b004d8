//! `experiments`: the FieldProbe command line (see the library docs for the subcommands).

fn main() -> anyhow::Result<()> {
    experiments::cli_main()
}
