//! The Python binding (feature `python`): the only code that knows pyo3 and
//! numpy. `convert` turns arrays and options into the core's types and
//! errors into exceptions, `robot` is the `CoreRobot` class (an arm of
//! either kind) whose methods release the GIL around batch work, `plant`
//! its calls on the plant, `results` the named result classes that cross
//! the boundary. No physics here.

mod convert;
mod plant;
mod results;
mod robot;

use pyo3::prelude::*;

#[pymodule]
fn _cdsm(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<robot::CoreRobot>()?;
    m.add_function(wrap_pyfunction!(robot::robot_kind, m)?)?;
    m.add_function(wrap_pyfunction!(robot::kind_info, m)?)?;
    results::register(m)?;
    m.add(
        "CdsmInputError",
        m.py().get_type::<convert::CdsmInputError>(),
    )?;
    m.add("PAPER_TOML", crate::model::PAPER_TOML)?;
    m.add("HIST_LO", crate::accuracy::HIST_LO)?;
    m.add("HIST_PER_DECADE", crate::accuracy::HIST_PER_DECADE)?;
    m.add("HIST_BINS", crate::accuracy::HIST_BINS)?;
    m.add("QUANTITIES", crate::accuracy::QUANTITIES)?;
    m.add("REASONS", crate::lm::Reason::NAMES.to_vec())?;
    m.add("ELASTIC_REASONS", crate::elastic::REASONS.to_vec())?;
    m.add("ELASTIC_XTOL", crate::elastic::XTOL)?;
    m.add("PLANT_REASONS", crate::plant::REASONS.to_vec())?;
    m.add("CLEARANCE_WIDTH", crate::plant::CLEARANCE_WIDTH)?;
    m.add("FRICTION_TYPICAL", crate::friction::MU_TYPICAL)?;
    m.add("FRICTION_MAX", crate::friction::MU_MAX)?;
    m.add_function(wrap_pyfunction!(robot::check_friction, m)?)?;
    m.add_function(wrap_pyfunction!(robot::hist_edges, m)?)?;
    m.add_function(wrap_pyfunction!(robot::simd_instruction_set, m)?)?;
    Ok(())
}
