//! Runs an experiment file through the fieldprobe library with the `stratified` sampler linked in.

use custom_sampler as _;

fn main() -> anyhow::Result<()> {
    fieldprobe::launch::main_with_linked_plugins()
}
