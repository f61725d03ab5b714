//! Rain, after Blanchard (2023, §4.2–4.3) and Rousseau et al. (2006, 2008):
//! the Marshall–Palmer drop-size distribution that ties the number of drops
//! to the rain intensity ([`dsd`]), drag and terminal fall speed ([`drag`]),
//! the wind field the drops are carried by ([`wind`]), the "rain box" of
//! drops around the camera and its recycling ([`rain_box`]), the rain zones
//! under the clouds ([`zones`]), what a drop refracts and reflects
//! ([`drop_optics`]), the overcast's light scattered by the rain mist
//! ([`mist_light`], and under a layer the column's own light as a slab,
//! [`mist_slab`]), and the CPU reference of the drop dynamics
//! that the GPU simulation runs step for step ([`simulation`]).
//!
//! Units: metres, seconds, m/s; drop diameters in millimetres where a name
//! says `_mm` (the meteorologists' unit), metres otherwise.

pub mod drag;
pub mod drop_optics;
pub mod dsd;
pub mod mist_light;
pub mod mist_slab;
pub mod rain_box;
pub mod random;
pub mod simulation;
pub mod wind;
pub mod zones;
