//! reference: independent Monte Carlo path tracer (under construction).
