//! The FieldProbe CLI with the `film` representation linked in.

use custom_model as _;

fn main() -> anyhow::Result<()> {
    experiments::cli_main()
}
