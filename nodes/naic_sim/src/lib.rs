//! Simulated JK5 + ATI mini45 (in progress).
