//! The interactive viewer (egui/eframe).
//!
//! Not built yet.
