"""The furnace's roulette in NumPy: why its error depends on the pass count, and what raising
the survival buys (docs/history/benchmarks-notebook.md,
"The eye paths' roulette").

    python docs/roulette_model.py

Model: in a furnace of albedo A every vertex a path reaches adds a constant, so the eye
paths' estimate past the first roulette is sum over k >= 1 of (A / q)^k [u < q^k], with u the
path's one roulette number and q the survival per bounce (mean A / (1 - A) for any q).  u is
a pixel's Owen-scrambled Sobol dimension over the passes, its pass index shuffled by a nested
uniform scramble as in kernels/rng.h (Burley 2020; a hash of the bit prefix decides each
flip, not rng.h's own hash).  A pass costs 5 + 2 E[survivals] rays (the eye ray, next-event
estimation and a sample at the visible point and at the first hit, two rays per survival), so
each q renders as many passes as q = A would in the same time.  Printed: RMSE over PIXELS
pixels against the mean, at the pass counts of 4 and 16 s in the eighth stop's run (58, 235)
and at the powers of two beside them."""
import numpy as np

A = 0.5
PIXELS = 4000
BITS = 20


def reverse_bits(n: np.ndarray, bits: int) -> np.ndarray:
    out = np.zeros_like(n)
    for i in range(bits):
        out |= ((n >> i) & 1) << (bits - 1 - i)
    return out


def owen(x: np.ndarray, bits: int, seeds: np.ndarray) -> np.ndarray:
    """Owen-scramble the top ``bits`` bits of x: each bit flips by a hash of the bits above it
    and the pixel's seed."""
    out = np.zeros_like(x)
    for level in range(bits):
        h = ((x >> (bits - level)) * 0x9E3779B1 + seeds[:, None] * 0x85EBCA77
             + level * 0xC2B2AE3D) & 0xFFFFFFFF
        h ^= h >> 15
        h = (h * 0x2C1B3C6D) & 0xFFFFFFFF
        h ^= h >> 12
        bit = (x >> (bits - 1 - level)) & 1
        out |= (bit ^ ((h >> 7) & 1)) << (bits - 1 - level)
    return out


def sobol_1d(passes: int, rng: np.random.Generator) -> np.ndarray:
    """(PIXELS, passes) numbers in [0, 1): the first dimension, index shuffled, then scrambled."""
    n = np.broadcast_to(np.arange(passes, dtype=np.int64), (PIXELS, passes))
    seeds = rng.integers(0, 2 ** 31, PIXELS, dtype=np.int64)
    shuffled = owen(reverse_bits(n, 16), 16, seeds ^ 12345)   # reversed, shuffled index
    return (owen(shuffled << (BITS - 16), BITS, seeds) + 0.5) / 2 ** BITS


def estimate(u: np.ndarray, q: float) -> np.ndarray:
    out = np.zeros_like(u)
    for k in range(1, 60):
        out += np.where(u < q ** k, (A / q) ** k, 0.0)
    return out


def cost(q: float) -> float:
    return 5 + 2 * q / (1 - q)


def main() -> None:
    rng = np.random.default_rng(1)
    mean = A / (1 - A)
    for q in (A, 0.6, float(np.sqrt(A)), 0.75):
        cells = []
        for passes_at_a in (58, 64, 235, 256):
            passes = max(1, round(passes_at_a * cost(A) / cost(q)))
            e = estimate(sobol_1d(passes, rng), q).mean(axis=1)
            cells.append(f"{passes} passes {np.sqrt(np.mean((e - mean) ** 2)):.4f}")
        print(f"q = {q:.3f} (cost {cost(q):.2f} rays): " + ", ".join(cells))


if __name__ == "__main__":
    main()
