//! Hydrodynamic journal-bearing film model (MODEL.md sections 1-7): parameters, states,
//! the default load rule, friction, the brute-force baseline and reference values.

mod baseline;
pub mod film_flow;
pub mod finite;
mod friction;
pub mod groove;
mod loads;
mod params;
pub mod reference;
mod rule;
mod state;

pub use baseline::baseline_loads;
pub use film_flow::{bearing_loads, FilmFlow, FrictionLaw};
pub use finite::{FilmModel, FiniteSettings};
pub use friction::{friction, Friction};
pub use groove::{Arc, Arcs, FilmLayout, Groove, Grooves};
pub use loads::{film_loads, finish_loads, pack_state, Loads, Packed};
pub use params::{BearingParams, ClearanceConvention, ParamError};
pub use rule::{
    quartic_roots, quartic_roots_counted, slice_integrals, Accuracy, FilmIntegrals, FilmRule,
    PackedState, RuleSettings, Singularities, ACCURACY_LEVELS,
};
pub use state::{BearingState, End, StateFault};
