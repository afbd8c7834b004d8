//! The FieldProbe CLI with the `stratified` sampler linked in.

use custom_sampler as _;

fn main() -> anyhow::Result<()> {
    experiments::cli_main()
}
