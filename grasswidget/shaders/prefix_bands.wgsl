// Between the two culling phases (see cull.wgsl): per LOD class, the first slot
// of each distance band (an exclusive prefix sum of the band counts, nearest
// band first) and the class's instance count for draw_indirect.

@group(0) @binding(0) var<storage, read_write> s_args: array<u32>;
@group(0) @binding(1) var<storage, read_write> s_bands: array<u32>;

const N_CLASSES: u32 = {{ n_classes }}u;
const BANDS: u32 = {{ bands }}u;
const KEYS: u32 = N_CLASSES * BANDS;

@compute @workgroup_size(1)
fn main() {
    for (var c = 0u; c < N_CLASSES; c += 1u) {
        var total = 0u;
        for (var b = 0u; b < BANDS; b += 1u) {
            let k = c * BANDS + b;
            s_bands[KEYS + k] = total;
            total += s_bands[k];
        }
        s_args[c * 4u + 1u] = total;
    }
}
