"""The studies behind docs/ and the benchmarks behind BENCHMARKS.md, as library code: each module's `main` is the
command its thin script in scripts/ calls; `runner` holds what they share."""
