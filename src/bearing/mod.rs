//! Hydrodynamic journal-bearing film model (MODEL.md sections 1-7): parameters, states,
//! the default load rule, friction, the brute-force baseline and reference values;
//! lubricants and the thermal balance (issue 24).

mod baseline;
pub mod film_flow;
pub mod finite;
mod friction;
pub mod groove;
mod loads;
pub mod lubricant;
mod params;
pub mod reference;
mod rule;
mod state;
pub mod thermal;

pub use baseline::baseline_loads;
pub use film_flow::{bearing_loads, FilmFlow, FrictionLaw};
pub use finite::{FilmModel, FiniteSettings};
pub use friction::{friction, Friction, FrictionConstants};
pub use groove::{Arc, Arcs, FilmLayout, Groove, Grooves};
pub use loads::{
    film_loads, finish_loads, finish_loads_using, finish_loads_with, pack_state, LoadConstants,
    Loads, Packed,
};
pub use lubricant::Lubricant;
pub use params::{BearingParams, ClearanceConvention, ParamError};
pub use rule::{
    atan2_lane, quartic_roots, quartic_roots_counted, quartic_roots_lanes, slice_integrals,
    slices_lanes, Accuracy, FilmIntegrals, FilmRule, LaneIsa, Lanes, PackedState, RuleSettings,
    Singularities, ACCURACY_LEVELS, LANES, ROOT_LANES,
};
pub use state::{planar_length, BearingState, End, StateFault, PLANAR_RANGE};
pub use thermal::{solve_balance, Balance, ThermalError, ThermalSettings};
