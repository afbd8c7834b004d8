//! Weights in and out as safetensors, through burn's own store (`burn::store`).
//!
//! Checkpoints stay burn records (`.bpk`: they carry the optimizer's state beside the model's).
//! Safetensors is what the rest of the field exchanges — Hugging Face, PyTorch
//! (`safetensors.torch`), JAX — so a trained model is exported as one, and a file written
//! elsewhere (an ImageNet ResNet for the encoder, a model another run exported) is imported by
//! tensor name. A representation's tensors are named by their module path
//! (`decoder.layers.0.weight`, `encoder.blocks.3.bn1.running_mean`); an [`Import`] renames a
//! foreign file's names onto those paths and says which of the model's tensors the file must
//! provide.

use std::path::Path;

use burn::module::Module;
use burn::store::{KeyRemapper, ModuleSnapshot, PyTorchToBurnAdapter, SafetensorsStore};

/// How a safetensors file's tensors map onto a model.
#[derive(Clone, Debug, Default)]
pub struct Import {
    /// `(regex, replacement)` rules applied in order to each of the file's tensor names
    /// (`("^conv1\\.", "encoder.stem.")`); a name no rule matches is kept as it is.
    pub rename: Vec<(String, String)>,
    /// The file is in PyTorch's layout (torchvision, `safetensors.torch.save_file`): batch-norm
    /// `weight`/`bias` are burn's `gamma`/`beta`, and a `Linear` weight is transposed.
    pub pytorch: bool,
    /// The model's tensors whose path starts with one of these must all come from the file; an
    /// empty list requires every tensor of the model.
    pub required: Vec<String>,
    /// Exceptions to `required`: tensors under these prefixes keep their values when the file
    /// lacks them (a new head, an input channel the file's network did not have).
    pub optional: Vec<String>,
}

/// What an import did.
#[derive(Clone, Debug, PartialEq)]
pub struct ImportReport {
    /// Model tensors given the file's values.
    pub loaded: usize,
    /// The file's tensors (after renaming) that no model tensor took, sorted.
    pub unused: Vec<String>,
}

/// Writes every tensor of `module` to `path` as safetensors (atomically: a scratch file renamed
/// into place), with `metadata` (for instance the model's TOML) in the file's header.
pub fn export<M: Module>(
    module: &M,
    path: &Path,
    metadata: &[(String, String)],
) -> Result<(), String> {
    let mut store = SafetensorsStore::from_file(path).overwrite(true);
    for (k, v) in metadata {
        store = store.metadata(k.clone(), v.clone());
    }
    module
        .save_into(&mut store)
        .map_err(|e| format!("{}: cannot write safetensors: {e}", path.display()))
}

/// Reads the tensors of the safetensors file at `path` into `module` by name (after
/// [`Import::rename`]). Fails, naming the file and the tensors, when a tensor's shape or type
/// differs from the model's or when a required tensor is missing; the module is left unchanged
/// by a failed import only if the failure is a missing file or an unreadable header.
pub fn import<M: Module>(
    module: &mut M,
    path: &Path,
    spec: &Import,
) -> Result<ImportReport, String> {
    let at = |e: String| format!("{}: {e}", path.display());
    if !path.is_file() {
        return Err(at("no such file".into()));
    }
    let mut remap = KeyRemapper::new();
    for (from, to) in &spec.rename {
        remap = remap
            .add_pattern(from, to)
            .map_err(|e| at(format!("bad rename rule {from:?}: {e}")))?;
    }
    let mut store = SafetensorsStore::from_file(path)
        .remap(remap)
        // Missing tensors and shape errors are judged below, with names and the file.
        .allow_partial(true)
        .validate(false);
    if spec.pytorch {
        store = store.with_from_adapter(PyTorchToBurnAdapter);
    }
    let result = module
        .load_from(&mut store)
        .map_err(|e| at(format!("cannot import: {e}")))?;
    if !result.errors.is_empty() {
        let errors: Vec<String> = result.errors.iter().map(|e| e.to_string()).collect();
        return Err(at(errors.join("; ")));
    }
    let missing: Vec<&str> = result
        .missing
        .iter()
        .map(|(name, _)| name.as_str())
        .filter(|name| {
            (spec.required.is_empty() || spec.required.iter().any(|p| name.starts_with(p)))
                && !spec.optional.iter().any(|p| name.starts_with(p))
        })
        .collect();
    if !missing.is_empty() {
        return Err(at(format!(
            "{} tensor(s) of the model are not in the file: {}",
            missing.len(),
            missing.join(", ")
        )));
    }
    let mut unused = result.unused.clone();
    unused.sort();
    Ok(ImportReport {
        loaded: result.applied.len(),
        unused,
    })
}
