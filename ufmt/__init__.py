"""ufmt: dynamics of ultra-precision fly-cutting machine tools (MSTMM)."""
