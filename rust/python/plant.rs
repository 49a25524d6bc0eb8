//! The plant's calls (`crate::plant`, `crate::fit`, `crate::compensate`) on
//! the one arm model, for the robot classes of either kind: arrays in, named
//! results out, the GIL released around the work.

use super::convert::{err, opt_slice, options, readings, slice, vec1, Arr, Array};
use super::results::{CompensationResult, PlantFit, PlantPrediction};
use crate::fit::{self, FitSpec};
use crate::kinds::{Group, Visit};
use crate::model::Model;
use crate::plant::{self, PlantFit as Fit, Rows, Sequence};
use pyo3::prelude::*;

/// Names and sizes of the plant's parameter blocks, in vector order.
pub fn effects(model: &Model) -> Vec<(String, usize)> {
    plant::layout(model)
        .blocks
        .iter()
        .map(|(e, _, s)| (e.name().to_string(), *s))
        .collect()
}

/// Every parameter of the plant, in vector order: its block's name, what it
/// is on the arm, its SI unit (`m`, `rad`, `1`, `1/N`).
pub fn parameters(model: &Model) -> Vec<(String, String, String)> {
    plant::parameters(model)
        .into_iter()
        .map(|p| {
            (
                p.effect.name().to_string(),
                p.label,
                p.unit.symbol().to_string(),
            )
        })
        .collect()
}

/// Lower and upper bounds of the plant's parameters (the physical domain).
pub fn bounds<'py>(py: Python<'py>, model: &Model) -> (Array<'py>, Array<'py>) {
    let (lo, hi) = plant::bounds(model);
    (vec1(py, lo), vec1(py, hi))
}

/// The rows of a data set: commands `theta_cmd (N, n)`, `dl (N, m)` and
/// each row's reading (from its code).
pub struct Data<'a> {
    pub theta_cmd: &'a [f64],
    pub dl: &'a [f64],
    pub reading: Vec<plant::Reading>,
}

impl<'a> Data<'a> {
    pub fn of(theta_cmd: &'a Arr<'_>, dl: &'a Arr<'_>, reading: &[u8]) -> PyResult<Self> {
        Ok(Data {
            theta_cmd: slice("theta_cmd", theta_cmd)?,
            dl: slice("dl", dl)?,
            reading: readings(reading)?,
        })
    }

    fn rows(&self) -> Rows<'_> {
        Rows {
            theta_cmd: self.theta_cmd,
            dl: self.dl,
            reading: &self.reading,
        }
    }
}

/// Predictions of the parameter sets `params (K, P)`.
pub fn predict(
    py: Python<'_>,
    model: &Model,
    params: Arr<'_>,
    data: &Data,
    tol: f64,
    max_iter: u32,
    threads: usize,
) -> PyResult<PlantPrediction> {
    let p = slice("params", &params)?;
    let o = options(tol, max_iter, false)?;
    let out = py
        .detach(|| plant::predict(model, p, &data.rows(), &o, threads))
        .map_err(err)?;
    Ok(PlantPrediction::new(py, out, None))
}

/// Predictions of one plant and their Jacobian with respect to `free`.
#[allow(clippy::too_many_arguments)]
pub fn linearise(
    py: Python<'_>,
    model: &Model,
    params: Arr<'_>,
    free: &[usize],
    data: &Data,
    tol: f64,
    max_iter: u32,
    threads: usize,
) -> PyResult<PlantPrediction> {
    let p = slice("params", &params)?;
    let o = options(tol, max_iter, false)?;
    let out = py
        .detach(|| plant::linearise(model, p, free, &data.rows(), &o, threads))
        .map_err(err)?;
    Ok(PlantPrediction::new(
        py,
        out.predictions,
        Some(out.jacobian),
    ))
}

/// What a fit of every fold needs besides the data.
pub struct FitArgs<'a> {
    pub measured: &'a [f64],
    pub scored: &'a [bool],
    /// The candidates' free parameters one after another (`widths[c]` of
    /// candidate `c`), and their scales.
    pub free: &'a [usize],
    pub scale: &'a [f64],
    pub widths: &'a [usize],
    /// The candidate each fold's fit fits.
    pub candidate: &'a [usize],
    pub start: &'a [f64],
    pub fit_iter: u32,
}

fn fit_k<G: Group>(
    model: &Model,
    seq: &Sequence,
    o: crate::solve::SolveOptions,
    a: &FitArgs,
    threads: usize,
) -> crate::Result<Vec<crate::fit::FitResult>> {
    let mut m = Fit::<G>::new(model, seq, o);
    // threads the folds leave idle go to the Jacobian's rows
    let folds = a.scored.len() / seq.rows().max(1);
    m.threads = (crate::rows::resolve_threads(threads) / folds.max(1)).max(1);
    if a.widths.iter().sum::<usize>() != a.free.len() {
        return Err(crate::error::CdsmError::Option {
            name: "widths".into(),
            problem: format!(
                "the candidates' widths add up to {}, not to the {} free parameters",
                a.widths.iter().sum::<usize>(),
                a.free.len()
            ),
        });
    }
    if a.scale.len() != a.free.len() {
        return Err(crate::error::CdsmError::Option {
            name: "scale".into(),
            problem: "needs one positive finite scale per free parameter".into(),
        });
    }
    let mut at = 0;
    let specs: Vec<_> = a
        .widths
        .iter()
        .map(|w| {
            let spec = FitSpec {
                model: &m,
                measured: a.measured,
                free: &a.free[at..at + w],
                scale: &a.scale[at..at + w],
                start: a.start,
                max_iter: a.fit_iter,
            };
            at += w;
            spec
        })
        .collect();
    fit::fit_each(&specs, a.candidate, a.scored, threads)
}

/// [`fit_k`] over the model's motion group.
struct FitVisit<'a> {
    model: &'a Model,
    seq: &'a Sequence,
    o: crate::solve::SolveOptions,
    args: &'a FitArgs<'a>,
    threads: usize,
}

impl Visit for FitVisit<'_> {
    type Out = crate::Result<Vec<crate::fit::FitResult>>;
    fn visit<G: Group>(self) -> Self::Out {
        fit_k::<G>(self.model, self.seq, self.o, self.args, self.threads)
    }
}

/// Fits the plant parameters `free` on every fold's scored rows.
pub fn fit(
    py: Python<'_>,
    model: &Model,
    data: &Data,
    args: FitArgs,
    tol: f64,
    max_iter: u32,
    threads: usize,
) -> PyResult<Vec<PlantFit>> {
    let o = options(tol, max_iter, false)?;
    let fits = py
        .detach(|| {
            let seq = Sequence::new(model, &data.rows())?;
            model.kind.visit(FitVisit {
                model,
                seq: &seq,
                o,
                args: &args,
                threads,
            })
        })
        .map_err(err)?;
    fits.into_iter().map(|f| PlantFit::new(py, f)).collect()
}

/// Compensated commands of `targets` on the plant `params`.
#[allow(clippy::too_many_arguments)]
pub fn compensate(
    py: Python<'_>,
    model: &Model,
    params: Arr<'_>,
    theta_cmd: Arr<'_>,
    targets: Arr<'_>,
    weights: &[f64],
    start: Option<Arr<'_>>,
    tol: f64,
    settle_tol: f64,
    max_iter: u32,
    threads: usize,
) -> PyResult<CompensationResult> {
    let p = slice("params", &params)?;
    let t = slice("theta_cmd", &theta_cmd)?;
    let g = slice("targets", &targets)?;
    let s = opt_slice("start", &start)?;
    let o = options(settle_tol, 100, false)?;
    let out = py
        .detach(|| {
            crate::compensate::compensate(model, p, t, g, weights, s, &o, tol, max_iter, threads)
        })
        .map_err(err)?;
    Ok(CompensationResult::new(py, out))
}
