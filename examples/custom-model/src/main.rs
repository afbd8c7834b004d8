//! Runs an experiment file through the fieldprobe library with the `film` representation linked in.

use custom_model as _;

fn main() -> anyhow::Result<()> {
    fieldprobe::launch::main_with_linked_plugins()
}
