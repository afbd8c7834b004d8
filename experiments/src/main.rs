//! `experiments`: the FieldProbe command line.
//!
//! ```text
//! experiments make-dataset --out DIR [--categories chair,table] [--train N --val N --test N] [--seed S]
//! experiments make-dataset --out DIR --meshes MESH_DIR [--split test]
//! experiments check-dataset --data DIR [--split test]
//! ```

mod check_dataset;
mod contact_sheet;
mod make_dataset;

use clap::{Parser, Subcommand};

// The explicit plugin link list: typetag registers components only from crates that are linked.
use fieldprobe_regularizers as _;
use fieldprobe_samplers as _;

#[derive(Parser, Debug)]
#[command(
    name = "experiments",
    version,
    about = "FieldProbe: implicit surfaces from silhouettes"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render meshes (procedural or .obj) into a dataset in Kato's npz layout (or DVR's).
    MakeDataset(make_dataset::Args),
    /// Load a dataset (ours or the published files) and report per category how its silhouettes,
    /// cameras and voxels agree (visual hull vs voxels).
    CheckDataset(check_dataset::Args),
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::MakeDataset(args) => make_dataset::run(args),
        Command::CheckDataset(args) => check_dataset::run(args),
    }
}
