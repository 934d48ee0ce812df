//! Baseline controllers that choose actions from the env state:
//! [`reservation`] (segment reservation, no head-on entries) and
//! [`random`] (uniform over the legal actions).
//!
//! ```
//! use std::sync::Arc;
//! use buridan_plant::controllers::{RandomController, ReservationController};
//! use buridan_plant::{Plant, PlantConfig, PlantEnv};
//! let plant = Arc::new(Plant::load("dissertation").unwrap());
//! let mut env = PlantEnv::new(plant, PlantConfig { agents: 2, ..Default::default() }).unwrap();
//! let mut controller = ReservationController::new(2);
//! let (mut actions, mut rewards) = ([0u8; 2], [0.0f32; 2]);
//! for _ in 0..100 {
//!     controller.actions(&env, &mut actions).unwrap();
//!     env.step(&actions, &mut rewards).unwrap();
//! }
//! assert_eq!(env.kpis().collisions, 0);
//! let mut random = RandomController::new(7);
//! random.actions(&env, &mut actions).unwrap();
//! ```

pub mod random;
pub mod reservation;

pub use random::RandomController;
pub use reservation::{footprint, ReservationController, Resource};
