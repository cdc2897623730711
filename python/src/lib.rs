//! The native half of the Python package `tolles`: the facade crate's workflows on columns
//! handed over from pandas. The Python half (`tolles/__init__.py`) builds DataFrames and models.
//!
//! Columns cross the boundary as float64 NumPy arrays. Only the columns a workflow needs are
//! copied in (once, into the table the library reads); every result column is handed back
//! without a copy. The GIL is released while the library computes.

use numpy::{IntoPyArray, PyReadonlyArray1};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyList;
use std::path::{Path, PathBuf};
use tolles::compensate::{CompensateRequest, LevelChoice};
use tolles::fit::{FitRequest, Lag, Terms};
use tolles::fom::FomRequest;
use tolles::model::ModelFile;
use tolles::{Silent, Warning};
use tolles_core::fit::{Band, Lambda, MagnitudeChoice};
use tolles_io::schema::{
    vector_columns, LINE_COLUMN, PITCH, ROLL, SAMPLE_INTERVAL, TIME_COLUMN, YAW,
};
use tolles_io::select::RowSelection;
use tolles_io::table::{find_column, Column, Table};

/// Float64 columns handed to Python without a copy.
type Arrays<'py> = Vec<Bound<'py, numpy::PyArray1<f64>>>;

create_exception!(
    _tolles,
    TollesError,
    PyValueError,
    "A flight, model or request tolles cannot use; the message names the file, row or column."
);

fn failed(e: impl std::fmt::Display) -> PyErr {
    TollesError::new_err(e.to_string())
}

/// The warnings as sentences; which rows a selection kept is what the caller asked for, not a
/// warning.
fn texts(warnings: &[Warning]) -> Vec<String> {
    warnings
        .iter()
        .filter(|w| !matches!(w, Warning::RowsSelected { .. }))
        .map(ToString::to_string)
        .collect()
}

/// A table of the named columns a workflow needs, taken from a DataFrame's columns: `names`
/// are all its column names (matched as the CLI matches them), `get(i)` returns column `i` as a
/// float64 array, `dt` is the sample interval (s) the file carried, if any.
struct Frame<'py> {
    source: PathBuf,
    names: Vec<String>,
    get: Bound<'py, PyAny>,
    dt: Option<f64>,
}

impl<'py> Frame<'py> {
    fn new(source: PathBuf, names: Vec<String>, get: Bound<'py, PyAny>, dt: Option<f64>) -> Self {
        Self {
            source,
            names,
            get,
            dt,
        }
    }

    /// The table of the columns `wanted` (each once, in that order) and the time column if the
    /// frame has one. A wanted column the frame lacks is an error that suggests near names.
    fn table(&self, wanted: &[String]) -> PyResult<Table> {
        self.table_with(wanted, &[TIME_COLUMN])
    }

    /// [`Frame::table`] with the `optional` columns the frame has, rather than time alone.
    fn table_with(&self, wanted: &[String], optional: &[&str]) -> PyResult<Table> {
        let mut chosen: Vec<usize> = Vec::new();
        let optional: Vec<String> = optional.iter().map(|o| o.to_string()).collect();
        for (name, required) in wanted
            .iter()
            .map(|w| (w, true))
            .chain(optional.iter().map(|o| (o, false)))
        {
            match find_column(&self.source, &self.names, name) {
                Ok(k) if !chosen.contains(&k) => chosen.push(k),
                Ok(_) => {}
                Err(e) if required => return Err(failed(e)),
                Err(_) => {}
            }
        }
        let mut columns = Vec::with_capacity(chosen.len());
        for &k in &chosen {
            let array = self.get.call1((k,))?;
            let array: PyReadonlyArray1<f64> = array.extract().map_err(|_| {
                failed(format!(
                    "{}: column {:?} is not numeric",
                    self.source.display(),
                    self.names[k]
                ))
            })?;
            columns.push(Column::Numbers(array.as_array().to_vec()));
        }
        let headers = chosen.iter().map(|&k| self.names[k].clone()).collect();
        let table = Table::from_columns(&self.source, headers, columns, None).map_err(failed)?;
        let metadata = self.dt.map(|dt| (SAMPLE_INTERVAL.to_string(), dt));
        Ok(table.with_metadata(metadata.into_iter().collect()))
    }
}

/// The columns compensating with `model` reads, time aside (optional in a frame: `dt` or
/// `fs` may give the rate): the facade's list, so Python reads what the CLI reads.
fn model_columns(model: &ModelFile) -> Vec<String> {
    tolles::compensate::columns_read(model)
        .into_iter()
        .filter(|c| c != TIME_COLUMN)
        .collect()
}

/// The attitude columns a maneuver search reads, and `scalar`.
fn attitude_and(scalar: &str) -> Vec<String> {
    let mut wanted: Vec<String> = [ROLL, PITCH, YAW].map(String::from).to_vec();
    wanted.push(scalar.to_string());
    wanted
}

/// An outcome's JSON, as the CLI prints it, and the warnings.
fn json_reply(value: serde_json::Value, warnings: &[Warning]) -> PyResult<(String, Vec<String>)> {
    let json = serde_json::to_string_pretty(&value).map_err(failed)?;
    Ok((json, texts(warnings)))
}

fn parse_model(json: &str) -> PyResult<ModelFile> {
    ModelFile::from_json(json, "<model>").map_err(failed)
}

/// Reads a flight in any format tolles reads; returns (names, columns, metadata, warnings),
/// each column a float64 array, or a list of str when its cells are not numbers.
#[pyfunction]
#[pyo3(signature = (path, lines=None, time=None, renames=None))]
#[allow(clippy::type_complexity)]
fn read<'py>(
    py: Python<'py>,
    path: PathBuf,
    lines: Option<Vec<String>>,
    time: Option<String>,
    renames: Option<Vec<(String, String)>>,
) -> PyResult<(
    Vec<String>,
    Bound<'py, PyList>,
    Vec<(String, f64)>,
    Vec<String>,
)> {
    let selection = selection(lines, time)?;
    let mut warnings = Vec::new();
    let data = py
        .detach(|| {
            let renames = renames.unwrap_or_default();
            tolles::read::read_renamed(&path, &selection, &renames, &Silent, &mut warnings)
        })
        .map_err(failed)?;
    let table = data.table;
    let columns = PyList::empty(py);
    for k in 0..table.headers().len() {
        match (&table.columns()[k], table.numeric_at(k)) {
            (_, Ok(values)) => columns.append(values.into_pyarray(py))?,
            (Column::Text(text), Err(_)) => {
                let cells: Vec<&str> = (0..text.len()).map(|r| text.get(r)).collect();
                columns.append(cells)?
            }
            (Column::Numbers(_), Err(e)) => return Err(failed(e)),
        }
    }
    let metadata = table.all_metadata().to_vec();
    Ok((
        table.headers().to_vec(),
        columns,
        metadata,
        texts(&warnings),
    ))
}

/// What `tolles.fit` asks for: a dict of its arguments, each checked in Python first.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
struct FitSettings {
    scalars: Vec<String>,
    vectors: Vec<String>,
    terms: String,
    lambda_: Option<f64>,
    /// Band-pass edges (Hz).
    band: (f64, f64),
    order: usize,
    trim: usize,
    /// Sample rate (Hz).
    fs: Option<f64>,
    magnitude: Option<String>,
    levels: Option<bool>,
    fluxgate_offset: Option<bool>,
    extras: Vec<String>,
    lag: Option<String>,
    reference: Option<String>,
    /// Train a network on what the linear model leaves (`fit --network`).
    network: bool,
    /// The network's own input columns.
    inputs: Vec<String>,
    /// Units per hidden layer.
    network_layers: Vec<usize>,
    network_activation: String,
    network_seed: u64,
    /// `stretches` or `lines`.
    network_held_out: String,
    /// The linear model refitted with the network (model 2c).
    network_joint: bool,
}

impl FitSettings {
    /// The facade's request, or an error naming the argument that cannot be one.
    fn request(self) -> PyResult<FitRequest> {
        let lag: Lag = self
            .lag
            .as_deref()
            .unwrap_or("none")
            .parse()
            .map_err(|e| failed(format!("lag: {e}")))?;
        let terms: Terms = self.terms.parse().map_err(failed)?;
        let magnitude = self
            .magnitude
            .as_deref()
            .map(str::parse::<MagnitudeChoice>)
            .transpose()
            .map_err(|e| failed(format!("magnitude: {e}")))?;
        let lambda = match self.lambda_ {
            None => Lambda::auto(),
            Some(x) if x.is_finite() && x >= 0.0 => Lambda::Fixed(x),
            Some(x) => {
                return Err(failed(format!(
                    "lambda_ must be \"auto\" or a number ≥ 0, got {x}"
                )))
            }
        };
        let extras =
            tolles::fit::parse_extras(&self.extras).map_err(|e| failed(format!("extras: {e}")))?;
        let network = match self.network {
            false => None,
            true => Some(tolles::fit::NetworkRequest {
                settings: tolles_core::fit::network::NetworkSettings {
                    hidden: self.network_layers,
                    activation: (self.network_activation.parse())
                        .map_err(|e| failed(format!("network_activation: {e}")))?,
                    seed: self.network_seed,
                    ..Default::default()
                },
                channels: self.inputs,
                held_out: (self.network_held_out.parse())
                    .map_err(|e| failed(format!("network_held_out: {e}")))?,
                joint: self.network_joint,
            }),
        };
        Ok(FitRequest {
            network,
            terms,
            lambda,
            band: Band {
                pass1_hz: self.band.0,
                pass2_hz: self.band.1,
            },
            order: self.order,
            trim: self.trim,
            fs_hz: self.fs,
            magnitude,
            levels: self.levels,
            fluxgate_offset: self.fluxgate_offset,
            extras,
            lag,
            reference: self.reference,
            ..FitRequest::new(self.scalars, self.vectors)
        })
    }
}

/// One frame as Python hands it over: (source, column names, column getter, dt in s).
type FrameArgs<'py> = (PathBuf, Vec<String>, Bound<'py, PyAny>, Option<f64>);

/// Fits a model with `settings` (a dict, see [`FitSettings`]) on one or several calibration
/// flights (`tolles::fit::fit_flights`); returns (model JSON, warnings).
#[pyfunction]
fn fit(
    py: Python<'_>,
    flights: Vec<FrameArgs<'_>>,
    settings: FitSettings,
) -> PyResult<(String, Vec<String>)> {
    let request = settings.request()?;
    let mut wanted = request.scalars.clone();
    wanted.extend(request.reference.iter().cloned());
    wanted.extend(request.vectors.iter().flat_map(|v| vector_columns(v)));
    wanted.extend(request.extras.iter().map(|e| e.name.clone()));
    wanted.extend(
        request
            .network
            .iter()
            .flat_map(|n| n.channels.iter().cloned()),
    );
    // The lines too, for a network that holds out whole lines.
    let tables = (flights.into_iter())
        .map(|(source, names, get, dt)| {
            Frame::new(source, names, get, dt).table_with(&wanted, &[TIME_COLUMN, LINE_COLUMN])
        })
        .collect::<PyResult<Vec<Table>>>()?;
    let mut warnings = Vec::new();
    let model = py
        .detach(|| tolles::fit::fit_flights(&tables, &request, &Silent, &mut warnings))
        .map_err(failed)?;
    Ok((model.to_json(), texts(&warnings)))
}

/// Compensates; returns ([(column name, values)], warnings).
#[pyfunction]
#[pyo3(signature = (source, names, get, dt, model, level, fs, uncertainty=false))]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
fn compensate<'py>(
    py: Python<'py>,
    source: PathBuf,
    names: Vec<String>,
    get: Bound<'py, PyAny>,
    dt: Option<f64>,
    model: &str,
    level: &str,
    fs: Option<f64>,
    uncertainty: bool,
) -> PyResult<(Vec<(String, Bound<'py, numpy::PyArray1<f64>>)>, Vec<String>)> {
    let model = parse_model(model)?;
    let request = CompensateRequest {
        fs_hz: fs,
        level: level.parse::<LevelChoice>().map_err(failed)?,
        uncertainty,
    };
    let frame = Frame::new(source, names, get, dt);
    let table = frame.table(&model_columns(&model))?;
    let mut warnings = Vec::new();
    let columns = py
        .detach(|| tolles::compensate::compensate(&table, &model, &request, &mut warnings))
        .map_err(failed)?;
    let mut out = Vec::new();
    // Renamed against every column of the frame, not only those read.
    let wanted: Vec<&str> = columns.iter().map(|c| c.name.as_str()).collect();
    let names = tolles_io::schema::output_names(&frame.names, &wanted);
    let trust = tolles::compensate::trust_columns(&frame.names, &columns);
    for ((column, (name, renamed)), trust) in columns.into_iter().zip(names).zip(trust) {
        if renamed {
            warnings.push(Warning::OutputRenamed {
                path: frame.source.clone(),
                wanted: column.name.clone(),
                renamed: name.clone(),
            });
        }
        out.push((name, column.values.into_pyarray(py)));
        for (name, values) in trust {
            out.push((name, values.into_pyarray(py)));
        }
    }
    Ok((out, texts(&warnings)))
}

/// The straight legs and box headings of a FOM: (nominal headings or `None` for the cardinal
/// ones, heading tolerance, level tolerance, cardinal tolerance), all in degrees.
type Legs = (Option<Vec<f64>>, f64, f64, f64);

fn with_legs(request: FomRequest, (headings, heading, level, cardinal): Legs) -> FomRequest {
    request.with_legs(headings, heading, level, cardinal)
}

/// The figure of merit; returns (JSON as `tolles fom --json` prints it, warnings).
#[pyfunction]
#[pyo3(signature = (source, names, get, dt, scalar, model, band, order, fs, legs))]
#[allow(clippy::too_many_arguments)]
fn fom(
    py: Python<'_>,
    source: PathBuf,
    names: Vec<String>,
    get: Bound<'_, PyAny>,
    dt: Option<f64>,
    scalar: String,
    model: Option<&str>,
    band: (f64, f64),
    order: usize,
    fs: Option<f64>,
    legs: Legs,
) -> PyResult<(String, Vec<String>)> {
    let model = model.map(parse_model).transpose()?;
    let fit = model
        .as_ref()
        .map(|m| tolles::fom::fit_for(m, Path::new("<model>"), &scalar))
        .transpose()
        .map_err(failed)?;
    let mut wanted = attitude_and(&scalar);
    if let Some(fit) = fit {
        // What compensating with the fit reads (time is optional, as in `model_columns`).
        let columns = tolles::compensate::fit_columns(fit);
        wanted.extend(columns.into_iter().filter(|c| c != TIME_COLUMN));
    }
    let table = Frame::new(source, names, get, dt).table(&wanted)?;
    let request = with_legs(
        FomRequest {
            band: Band {
                pass1_hz: band.0,
                pass2_hz: band.1,
            },
            order,
            fs_hz: fs,
            ..FomRequest::new(&scalar)
        },
        legs,
    );
    let mut warnings = Vec::new();
    let outcome = py
        .detach(|| tolles::fom::fom(&table, &request, fit, &mut warnings))
        .map_err(failed)?;
    json_reply(outcome.to_json(), &warnings)
}

/// The patent's procedure; returns (JSON as `tolles procedure --json` prints it, warnings).
#[pyfunction]
#[pyo3(signature = (source, names, get, dt, scalar, vector, dip_deg, declination_deg, ignore))]
#[allow(clippy::too_many_arguments)]
fn procedure(
    py: Python<'_>,
    source: PathBuf,
    names: Vec<String>,
    get: Bound<'_, PyAny>,
    dt: Option<f64>,
    scalar: String,
    vector: Option<String>,
    dip_deg: Option<f64>,
    declination_deg: f64,
    ignore: Vec<String>,
) -> PyResult<(String, Vec<String>)> {
    use tolles::procedure::{Direction, ProcedureRequest};
    let direction = match (vector, dip_deg) {
        (Some(vector), None) => Direction::Fluxgate { vector },
        (None, Some(dip_deg)) => Direction::Attitude { dip_deg },
        _ => {
            return Err(failed(
                "give either a fluxgate (vector) or the field's dip (dip), not both",
            ))
        }
    };
    let mut wanted = attitude_and(&scalar);
    if let Direction::Fluxgate { vector } = &direction {
        wanted.extend(vector_columns(vector));
    }
    let table = Frame::new(source, names, get, dt).table(&wanted)?;
    let request = ProcedureRequest {
        declination_deg,
        ignore,
        ..ProcedureRequest::new(&scalar, direction)
    };
    let mut warnings = Vec::new();
    let outcome = py
        .detach(|| tolles::procedure::procedure(&table, &request, &mut warnings))
        .map_err(failed)?;
    json_reply(outcome.to_json(), &warnings)
}

/// How well a plan or a flown flight determines each term; returns (JSON as `tolles plan
/// --json` prints it, warnings). `maneuvers` is `box`, `patent`, or a list `roll@0,…`.
#[pyfunction]
#[pyo3(signature = (maneuvers, without, flight, vector, terms, noise_nt, dip_deg, declination_deg, intensity_nt, fs))]
#[allow(clippy::too_many_arguments)]
fn plan(
    py: Python<'_>,
    maneuvers: String,
    without: Vec<String>,
    flight: Option<PathBuf>,
    vector: String,
    terms: &str,
    noise_nt: f64,
    dip_deg: f64,
    declination_deg: f64,
    intensity_nt: f64,
    fs: Option<f64>,
) -> PyResult<(String, Vec<String>)> {
    use tolles::plan::{BuiltinPlan, Maneuvers, PlanRequest};
    use tolles_core::flight::plan::Axis;
    let axis = |name: &String| match name.trim().to_ascii_lowercase().as_str() {
        "roll" => Ok(Axis::Roll),
        "pitch" => Ok(Axis::Pitch),
        "yaw" => Ok(Axis::Yaw),
        other => Err(failed(format!(
            "without: expected roll, pitch or yaw, got {other:?}"
        ))),
    };
    let builtin = |plan| -> PyResult<Maneuvers> {
        let without = without.iter().map(axis).collect::<PyResult<_>>()?;
        Ok(Maneuvers::Builtin { plan, without })
    };
    let maneuvers = match (flight, maneuvers.trim().to_ascii_lowercase().as_str()) {
        (Some(path), _) => Maneuvers::Flown {
            path,
            vector,
            selection: RowSelection::default(),
            renames: Vec::new(),
            fs_hz: fs,
        },
        (None, "box") => builtin(BuiltinPlan::Box)?,
        (None, "patent") => builtin(BuiltinPlan::Patent)?,
        (None, _) => Maneuvers::List(maneuvers),
    };
    let request = PlanRequest {
        maneuvers,
        terms: terms.parse().map_err(failed)?,
        noise_nt,
        field: tolles_core::flight::sim::EarthField {
            intensity_nt,
            inclination_deg: dip_deg,
            declination_deg,
        },
    };
    let mut warnings = Vec::new();
    let outcome = py
        .detach(|| tolles::plan::plan(&request, &Silent, &mut warnings))
        .map_err(failed)?;
    json_reply(outcome.to_json(), &warnings)
}

/// The columns `compensate` adds to a frame with columns `names`, in the model's order.
#[pyfunction]
#[pyo3(signature = (model, names, uncertainty=false))]
fn output_names(model: &str, names: Vec<String>, uncertainty: bool) -> PyResult<Vec<String>> {
    let model = parse_model(model)?;
    let wanted: Vec<&str> = model
        .fits
        .iter()
        .map(|f| f.output_column.as_str())
        .collect();
    let mut out = Vec::new();
    for (name, _) in tolles_io::schema::output_names(&names, &wanted) {
        if uncertainty {
            let added = tolles_io::schema::trust_columns(&name);
            let added: Vec<&str> = added.iter().map(String::as_str).collect();
            let unique = tolles_io::schema::output_names(&names, &added);
            out.push(name);
            out.extend(unique.into_iter().map(|(n, _)| n));
        } else {
            out.push(name);
        }
    }
    Ok(out)
}

/// Converts the flight file `input` to `output` (CSV, HDF5 or Parquet by extension), as
/// `tolles convert` does. Returns (rows, columns, padded as (name, length), warnings).
#[pyfunction]
#[pyo3(signature = (input, output, lines=None, time=None, renames=None))]
#[allow(clippy::type_complexity)]
fn convert(
    py: Python<'_>,
    input: PathBuf,
    output: PathBuf,
    lines: Option<Vec<String>>,
    time: Option<String>,
    renames: Option<Vec<(String, String)>>,
) -> PyResult<(usize, usize, Vec<(String, usize)>, Vec<String>)> {
    let request = tolles::convert::ConvertRequest {
        selection: selection(lines, time)?,
        renames: renames.unwrap_or_default(),
        ..tolles::convert::ConvertRequest::new(input, output)
    };
    let mut warnings = Vec::new();
    let done = py
        .detach(|| tolles::convert::convert(&request, &Silent, &mut warnings))
        .map_err(failed)?;
    Ok((done.rows, done.columns, done.padded, texts(&warnings)))
}

/// Writes the HTML report of `flight` (each of `scalars`, or every fit of `model`) into `out`,
/// as `tolles report` does, and prints it to `pdf` if given; returns (index.html's path,
/// warnings).
#[pyfunction]
#[pyo3(signature = (flight, out, model, scalars, lines, time, renames, band, order, fs, pdf, legs, noise_tolerance, reference, fom_spec, heading_error_spec, paper))]
#[allow(clippy::too_many_arguments)]
fn report(
    py: Python<'_>,
    flight: PathBuf,
    out: PathBuf,
    model: Option<PathBuf>,
    scalars: Vec<String>,
    lines: Option<Vec<String>>,
    time: Option<String>,
    renames: Option<Vec<(String, String)>>,
    band: (f64, f64),
    order: usize,
    fs: Option<f64>,
    pdf: Option<PathBuf>,
    legs: Legs,
    noise_tolerance: f64,
    reference: Option<String>,
    fom_spec: f64,
    heading_error_spec: f64,
    paper: String,
) -> PyResult<(PathBuf, Vec<String>)> {
    let (headings, heading, level, cardinal) = legs;
    let request = tolles::report::ReportRequest {
        scalar: None,
        model,
        band: Band {
            pass1_hz: band.0,
            pass2_hz: band.1,
        },
        order,
        fs_hz: fs,
        selection: selection(lines, time)?,
        renames: renames.unwrap_or_default(),
        noise_tolerance_nt: noise_tolerance,
        fom_spec_nt: fom_spec,
        heading_error_spec_nt: heading_error_spec,
        paper: paper
            .parse()
            .map_err(|e: String| failed(format!("paper: {e}")))?,
        reference,
        ..tolles::report::ReportRequest::new(flight, "")
    }
    .with_legs(headings, heading, level, cardinal);
    let mut warnings = Vec::new();
    let index = py.detach(|| -> Result<PathBuf, String> {
        let data = tolles::report::build_each(&request, &scalars, &Silent, &mut warnings)
            .map_err(|e| e.to_string())?;
        let index =
            tolles_report::flight::write_each(&data, &warnings, &out).map_err(|e| e.to_string())?;
        if let Some(pdf) = &pdf {
            tolles_report::export::print_pdf(&index, pdf).map_err(|e| e.to_string())?;
        }
        Ok(index)
    });
    Ok((index.map_err(failed)?, texts(&warnings)))
}

/// The row selection of Python's `line` ids and `time` range text.
fn selection(lines: Option<Vec<String>>, time: Option<String>) -> PyResult<RowSelection> {
    Ok(RowSelection {
        lines: lines
            .unwrap_or_default()
            .iter()
            .map(|l| l.parse().map_err(failed))
            .collect::<PyResult<_>>()?,
        time: time.map(|t| t.parse().map_err(failed)).transpose()?,
    })
}

/// The model file at `path` as JSON text (checked).
#[pyfunction]
fn load_model(path: PathBuf) -> PyResult<String> {
    Ok(tolles::model::load_model(&path).map_err(failed)?.to_json())
}

/// Checks model JSON text and returns it as tolles writes it.
#[pyfunction]
fn check_model(json: &str) -> PyResult<String> {
    Ok(parse_model(json)?.to_json())
}

/// Writes model JSON text to `path` exactly as `tolles fit --out` does.
#[pyfunction]
fn save_model(json: &str, path: PathBuf) -> PyResult<()> {
    tolles::model::save_model(&parse_model(json)?, &path).map_err(failed)
}

/// Simulates a flight; `options` is a JSON object of `SimulateRequest` fields by name.
/// Returns (names, columns, sidecar JSON).
#[pyfunction]
fn simulate<'py>(py: Python<'py>, options: &str) -> PyResult<(Vec<String>, Arrays<'py>, String)> {
    let request = simulate_request(options)?;
    let simulated = py
        .detach(|| tolles::simulate::simulate(&request, &Silent))
        .map_err(failed)?;
    let columns = tolles::simulate::output::flight_columns(&simulated.flight);
    let names = columns.iter().map(|(n, _)| n.to_string()).collect();
    let arrays = columns
        .iter()
        .map(|(_, v)| v.to_vec().into_pyarray(py))
        .collect();
    let sidecar = tolles::simulate::output::Sidecar::new(
        simulated.plan_kind.name(),
        &simulated.plan,
        &simulated.scenario,
    );
    Ok((names, arrays, sidecar.to_json()))
}

fn simulate_request(options: &str) -> PyResult<tolles::simulate::SimulateRequest> {
    use tolles::simulate::{SimulateRequest, UniformField};
    let value: serde_json::Value = serde_json::from_str(options).map_err(failed)?;
    let object = value
        .as_object()
        .ok_or_else(|| failed("options must be a mapping"))?;
    let mut r = SimulateRequest::default();
    for (key, v) in object {
        let number = || {
            v.as_f64()
                .ok_or_else(|| failed(format!("{key} must be a number, got {v}")))
        };
        let count = || {
            v.as_u64()
                .ok_or_else(|| failed(format!("{key} must be a whole number ≥ 0, got {v}")))
        };
        let text = || {
            v.as_str()
                .ok_or_else(|| failed(format!("{key} must be text, got {v}")))
        };
        match key.as_str() {
            "plan" => r.plan = text()?.parse().map_err(failed)?,
            "preset" => r.preset = text()?.parse().map_err(failed)?,
            "seed" => r.seed = count()?,
            "fs" => r.fs_hz = number()?,
            "speed" => r.speed_mps = number()?,
            "lat" => r.lat_deg = number()?,
            "lon" => r.lon_deg = number()?,
            "alt" => r.alt_m = number()?,
            "date" => r.date = text()?.to_string(),
            "uniform" => {
                let [inclination_deg, declination_deg, intensity_nt]: [f64; 3] =
                    serde_json::from_value(v.clone()).map_err(|_| {
                        failed("uniform must be (inclination_deg, declination_deg, intensity_nT)")
                    })?;
                r.uniform = Some(UniformField {
                    inclination_deg,
                    declination_deg,
                    intensity_nt,
                });
            }
            "period" => r.period_s = number()?,
            "cycles" => r.cycles = count()?.try_into().map_err(failed)?,
            "roll" => r.roll_deg = Some(number()?),
            "pitch" => r.pitch_deg = Some(number()?),
            "yaw" => r.yaw_deg = number()?,
            "lines" => r.lines = count()?.try_into().map_err(failed)?,
            "line_duration" => r.line_duration_s = number()?,
            "turbulence" => r.turbulence_deg = number()?,
            "geology" => r.geology_nt = number()?,
            "diurnal" => r.diurnal_nt = number()?,
            "scalar_noise" => r.scalar_noise_nt = number()?,
            "flux_noise" => r.flux_noise_nt = number()?,
            "flux_lag" => r.flux_lag_s = number()?,
            "effects" => r.effects = text()?.parse().map_err(failed)?,
            "reference" => {
                r.reference = v
                    .as_bool()
                    .ok_or_else(|| failed(format!("reference must be True or False, got {v}")))?
            }
            "reference_noise" => r.reference_noise_nt = number()?,
            other => return Err(failed(format!("simulate has no option {other:?}"))),
        }
    }
    Ok(r)
}

#[pymodule]
fn _tolles(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("TollesError", m.py().get_type::<TollesError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(read, m)?)?;
    m.add_function(wrap_pyfunction!(convert, m)?)?;
    m.add_function(wrap_pyfunction!(fit, m)?)?;
    m.add_function(wrap_pyfunction!(compensate, m)?)?;
    m.add_function(wrap_pyfunction!(fom, m)?)?;
    m.add_function(wrap_pyfunction!(report, m)?)?;
    m.add_function(wrap_pyfunction!(output_names, m)?)?;
    m.add_function(wrap_pyfunction!(procedure, m)?)?;
    m.add_function(wrap_pyfunction!(plan, m)?)?;
    m.add_function(wrap_pyfunction!(load_model, m)?)?;
    m.add_function(wrap_pyfunction!(check_model, m)?)?;
    m.add_function(wrap_pyfunction!(save_model, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    Ok(())
}
