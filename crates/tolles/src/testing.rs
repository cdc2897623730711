//! Flights for the unit tests: simulated, held in memory as the readers would hold them.

use crate::simulate::output::flight_columns;
use crate::simulate::{simulate, PlanKind, SimulateRequest};
use crate::Silent;
use tolles_io::table::{Column, Table};

/// A cabin installation flying `plan`, as a table of number columns named like the CLI's CSV.
pub fn flight(plan: PlanKind, seed: u64) -> Table {
    flight_of(plan, seed, SimulateRequest::default().preset)
}

/// [`flight`] of the installation `preset`.
pub fn flight_of(plan: PlanKind, seed: u64, preset: crate::simulate::Preset) -> Table {
    let request = SimulateRequest {
        plan,
        seed,
        lines: 2,
        preset,
        ..SimulateRequest::default()
    };
    let simulated = simulate(&request, &Silent).expect("a valid simulation");
    let columns = flight_columns(&simulated.flight);
    Table::from_columns(
        format!("{}.csv", plan.name()),
        columns.iter().map(|(name, _)| name.to_string()).collect(),
        columns
            .iter()
            .map(|(_, v)| Column::Numbers(v.to_vec()))
            .collect(),
        None,
    )
    .expect("simulated columns form a table")
}
