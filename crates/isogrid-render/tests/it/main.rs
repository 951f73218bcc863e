//! Integration tests of the render front door: request validation, the backend policy, and
//! dispatch with progress and cancellation on both renderers.

mod dispatch;
mod labels;
mod policy;
mod request;
mod scene;
