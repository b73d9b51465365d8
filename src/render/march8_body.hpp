// The body of the ray caster's 8-lane inner loop (march8.cpp), included twice: once compiled
// for AVX2 and once for AVX-512 (F/VL/BW/DQ: 32 vector registers, EVEX masks), both without
// FMA contraction so either performs the scalar march's operations exactly. The includer
// defines STRATA_MARCH8_NAME and STRATA_MARCH8_ATTRS and provides the helpers it uses.
// No include guard: meant to be included more than once, inside march8.cpp's namespace.

template <bool Shade>
STRATA_MARCH8_ATTRS std::int64_t STRATA_MARCH8_NAME(const GridSampler& s, const Block& b, const LevelParams& lp,
                                           const MarchParams& mp, const RayContext& ray, const float p[3],
                                           const float dp[3], std::int64_t k0, std::int64_t k, std::int64_t k1,
                                           bool skip, float& front, std::int64_t& last, Rgbaf& acc_io,
                                           std::uint64_t& taken) {
  const __m256 lane = _mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i lane_i = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
  const __m256i sx = _mm256_set1_epi32(int(s.dx)), sy = _mm256_set1_epi32(int(s.dy)), sz = _mm256_set1_epi32(int(s.dz));
  const int oy = int(s.dy), oz = int(s.dz);
  const __m256 vlo = _mm256_set1_ps(mp.value_lo), vscale = _mm256_set1_ps(mp.value_scale);
  const Classifier& cl = lp.classify;
  const __m256 bins_f = _mm256_set1_ps(float(Transparency::kBins));
  const __m256i bin_max = _mm256_set1_epi32(Transparency::kBins - 1), low16 = _mm256_set1_epi32(0xffff);
  const int* next_visible = reinterpret_cast<const int*>(mp.next_visible);
  const float term = mp.termination;
  const __m256i zero_i = _mm256_setzero_si256(), low8 = _mm256_set1_epi32(0xff);
  const __m256i cells_x = _mm256_set1_epi32(b.cells[0]), cells_y = _mm256_set1_epi32(b.cells[1]);
  const __m256i cell_max_x = _mm256_set1_epi32(b.cells[0] - 1), cell_max_y = _mm256_set1_epi32(b.cells[1] - 1),
                cell_max_z = _mm256_set1_epi32(b.cells[2] - 1);
  __m128 acc = _mm_setr_ps(acc_io.r, acc_io.g, acc_io.b, acc_io.a);
  bool have_front = true;
  alignas(32) float xs[8], ys[8], zs[8], vs[8];
  while (k < k1) {
    const int n = int(std::min<std::int64_t>(8, k1 - k));
    const __m256 j = _mm256_add_ps(_mm256_set1_ps(float(k - k0)), lane);
    __m256 x = _mm256_add_ps(_mm256_set1_ps(p[0]), _mm256_mul_ps(_mm256_set1_ps(dp[0]), j));
    __m256 y = _mm256_add_ps(_mm256_set1_ps(p[1]), _mm256_mul_ps(_mm256_set1_ps(dp[1]), j));
    __m256 z = _mm256_add_ps(_mm256_set1_ps(p[2]), _mm256_mul_ps(_mm256_set1_ps(dp[2]), j));
    _mm256_store_ps(xs, x);
    _mm256_store_ps(ys, y);
    _mm256_store_ps(zs, z);
    if (skip) {  // Block::empty_at for the 8 lanes
      const __m256 inv = _mm256_set1_ps(1.0f / float(detail::kCell));
      const __m256i cx = _mm256_min_epi32(_mm256_max_epi32(_mm256_cvttps_epi32(_mm256_mul_ps(x, inv)), zero_i), cell_max_x);
      const __m256i cy = _mm256_min_epi32(_mm256_max_epi32(_mm256_cvttps_epi32(_mm256_mul_ps(y, inv)), zero_i), cell_max_y);
      const __m256i cz = _mm256_min_epi32(_mm256_max_epi32(_mm256_cvttps_epi32(_mm256_mul_ps(z, inv)), zero_i), cell_max_z);
      const __m256i cell = _mm256_add_epi32(_mm256_mullo_epi32(_mm256_add_epi32(_mm256_mullo_epi32(cz, cells_y), cy), cells_x), cx);
      const __m256i flag = _mm256_and_si256(_mm256_i32gather_epi32(reinterpret_cast<const int*>(b.empty), cell, 1), low8);
      const __m256i valid = _mm256_cmpgt_epi32(_mm256_set1_epi32(n), lane_i);
      const unsigned open = unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_and_si256(_mm256_cmpeq_epi32(flag, zero_i), valid))));
      if (open == 0) {  // every segment of the chunk is transparent
        have_front = false;
        k += n;
        continue;
      }
      const int first = __builtin_ctz(open);
      if (first >= kRealign) {  // the chunk restarts at its first open lane (busier lanes)
        have_front = false;
        k += first;
        continue;
      }
    }
    if (!have_front) {  // resuming after skipped chunks: the value at k - 1 afresh
      const float jm = float(k - k0) - 1.0f;
      front = normalised_sample(s, p[0] + dp[0] * jm, p[1] + dp[1] * jm, p[2] + dp[2] * jm, mp.value_lo, mp.value_scale);
      ++taken;
      have_front = true;
    }
    // Trilinear values (GridSampler::operator()) at the lattice points and at the segments'
    // midpoints, half a step back (Marcher::segment, split_pair).
    const __m256 v = trilinear8(s, x, y, z, vlo, vscale);
    const __m256 half = _mm256_set1_ps(0.5f);
    const __m256 mid = trilinear8(s, _mm256_sub_ps(x, _mm256_mul_ps(_mm256_set1_ps(dp[0]), half)),
                                  _mm256_sub_ps(y, _mm256_mul_ps(_mm256_set1_ps(dp[1]), half)),
                                  _mm256_sub_ps(z, _mm256_mul_ps(_mm256_set1_ps(dp[2]), half)), vlo, vscale);
    _mm256_store_ps(vs, v);
    // Fronts: the previous lane's value; lane 0 takes the carried front.
    const __m256 fr = _mm256_blend_ps(_mm256_permutevar8x32_ps(v, _mm256_setr_epi32(0, 0, 1, 2, 3, 4, 5, 6)),
                                      _mm256_set1_ps(front), 0x01);
    // Transparency bins (Transparency::bin, next_visible).
    const __m256 lo = _mm256_min_ps(_mm256_min_ps(fr, v), mid), hi = _mm256_max_ps(_mm256_max_ps(fr, v), mid);
    const __m256i blo = _mm256_min_epi32(_mm256_cvttps_epi32(_mm256_mul_ps(_mm256_min_ps(_mm256_max_ps(lo, zero), one), bins_f)), bin_max);
    const __m256i bhi = _mm256_min_epi32(_mm256_cvttps_epi32(_mm256_mul_ps(_mm256_min_ps(_mm256_max_ps(hi, zero), one), bins_f)), bin_max);
    // Lanes whose segment starts or ends at a NaN or infinite value (x - x is 0 only for finite
    // x) are empty space, as in the scalar march.
    const __m256 finite = _mm256_and_ps(_mm256_and_ps(_mm256_cmp_ps(_mm256_sub_ps(v, v), zero, _CMP_EQ_OQ),
                                                      _mm256_cmp_ps(_mm256_sub_ps(fr, fr), zero, _CMP_EQ_OQ)),
                                        _mm256_cmp_ps(_mm256_sub_ps(mid, mid), zero, _CMP_EQ_OQ));
    const __m256i valid =
        _mm256_and_si256(_mm256_cmpgt_epi32(_mm256_set1_epi32(n), lane_i), _mm256_castps_si256(finite));
    const __m256i nv = _mm256_and_si256(_mm256_i32gather_epi32(next_visible, blo, 2), low16);
    const __m256i visible = _mm256_xor_si256(_mm256_cmpgt_epi32(nv, bhi), _mm256_set1_epi32(-1));
    const unsigned keep = unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_and_si256(visible, valid))));
    if (keep == 0) {
      front = vs[n - 1];
      last = k + n - 1;
      taken += std::uint64_t(n);
      k += n;
      continue;
    }
    // Pre-integrated classification of the two halves of every lane's segment (split_pair; the
    // table indices are clamped, so lanes outside `keep` read valid entries and are zeroed
    // afterwards).
    __m256 cr, cg, cb, ca;
    {
      __m256 r1, g1, b1, a1, r2, g2, b2, a2;
      classify8(cl, fr, mid, r1, g1, b1, a1);
      classify8(cl, mid, v, r2, g2, b2, a2);
      half_segment8(r1, g1, b1, a1);
      half_segment8(r2, g2, b2, a2);
      const __m256 t = _mm256_sub_ps(one, a1);
      cr = _mm256_add_ps(r1, _mm256_mul_ps(t, r2));
      cg = _mm256_add_ps(g1, _mm256_mul_ps(t, g2));
      cb = _mm256_add_ps(b1, _mm256_mul_ps(t, b2));
      ca = _mm256_add_ps(a1, _mm256_mul_ps(t, a2));
      // Lanes past the block's end, transparent segments and zero opacity contribute nothing.
      const __m256 live = _mm256_and_ps(_mm256_castsi256_ps(_mm256_and_si256(visible, valid)),
                                        _mm256_cmp_ps(ca, zero, _CMP_GT_OQ));
      cr = _mm256_and_ps(cr, live);
      cg = _mm256_and_ps(cg, live);
      cb = _mm256_and_ps(cb, live);
      ca = _mm256_and_ps(ca, live);
    }
    if constexpr (Shade) {
      const unsigned want = unsigned(_mm256_movemask_ps(_mm256_cmp_ps(ca, _mm256_set1_ps(lp.shade_threshold), _CMP_GT_OQ)));
      if (want) {
        // Gradients at the segments' midpoints, half a step back (Marcher::segment): the 32-voxel
        // stencil (GridSampler::gradient) for lanes inside the grid's interior, by masked
        // gathers, the midpoint's trilinear taps gathered afresh; other lanes scalar.
        alignas(32) float mxs[8], mys[8], mzs[8];
        const __m256 xu = _mm256_sub_ps(_mm256_load_ps(xs), _mm256_mul_ps(_mm256_set1_ps(dp[0]), half));
        const __m256 yu = _mm256_sub_ps(_mm256_load_ps(ys), _mm256_mul_ps(_mm256_set1_ps(dp[1]), half));
        const __m256 zu = _mm256_sub_ps(_mm256_load_ps(zs), _mm256_mul_ps(_mm256_set1_ps(dp[2]), half));
        _mm256_store_ps(mxs, xu);
        _mm256_store_ps(mys, yu);
        _mm256_store_ps(mzs, zu);
        const __m256 in = _mm256_and_ps(
            _mm256_and_ps(_mm256_and_ps(_mm256_cmp_ps(xu, one, _CMP_GE_OQ), _mm256_cmp_ps(yu, one, _CMP_GE_OQ)),
                          _mm256_and_ps(_mm256_cmp_ps(zu, one, _CMP_GE_OQ), _mm256_cmp_ps(xu, _mm256_set1_ps(float(s.nx - 2)), _CMP_LT_OQ))),
            _mm256_and_ps(_mm256_cmp_ps(yu, _mm256_set1_ps(float(s.ny - 2)), _CMP_LT_OQ),
                          _mm256_cmp_ps(zu, _mm256_set1_ps(float(s.nz - 2)), _CMP_LT_OQ)));
        // (a few lanes are cheaper one by one than 32 gathers)
        const unsigned inside = __builtin_popcount(want & unsigned(_mm256_movemask_ps(in))) > 2
                                    ? unsigned(_mm256_movemask_ps(in))
                                    : 0u;
        __m256 gx = zero, gy = zero, gz = zero;
        if (inside) {
          // Lanes outside `in` take index 0 (their taps are masked out, their gradients unused).
          const __m256i in_i = _mm256_castps_si256(in);
          const __m256i mix = _mm256_cvttps_epi32(xu), miy = _mm256_cvttps_epi32(yu), miz = _mm256_cvttps_epi32(zu);
          const __m256 mfx = _mm256_sub_ps(xu, _mm256_cvtepi32_ps(mix)), mfy = _mm256_sub_ps(yu, _mm256_cvtepi32_ps(miy)),
                       mfz = _mm256_sub_ps(zu, _mm256_cvtepi32_ps(miz));
          const __m256i mbase = _mm256_and_si256(
              _mm256_add_epi32(_mm256_add_epi32(_mm256_mullo_epi32(mix, sx), _mm256_mullo_epi32(miy, sy)), _mm256_mullo_epi32(miz, sz)),
              in_i);
#define STRATA_G(off) _mm256_mask_i32gather_ps(zero, s.data, _mm256_add_epi32(mbase, _mm256_set1_epi32(off)), in, 4)
#define STRATA_LERP(a, b, w) _mm256_add_ps((a), _mm256_mul_ps((w), _mm256_sub_ps((b), (a))))
#define STRATA_LIN(off) lin_pair(s.data, mbase, (off), in_i, mfx)
#define STRATA_ROWD(off, b_, c_) row_diff(STRATA_G((off) - 1), (b_), (c_), STRATA_G((off) + 2), mfx)
#define STRATA_DIFF(f, lo_m, l0, l1, hi_p) \
  STRATA_LERP(_mm256_sub_ps((l1), (lo_m)), _mm256_sub_ps((hi_p), (l0)), (f))
          // The midpoint's eight trilinear taps, as rows of pairs along x (the stencil's centre).
          __m256 q000, q100, q010, q110, q001, q101, q011, q111;
          gather_pairs(s.data, mbase, in_i, q000, q100);
          gather_pairs(s.data, _mm256_add_epi32(mbase, _mm256_set1_epi32(oy)), in_i, q010, q110);
          gather_pairs(s.data, _mm256_add_epi32(mbase, _mm256_set1_epi32(oz)), in_i, q001, q101);
          gather_pairs(s.data, _mm256_add_epi32(mbase, _mm256_set1_epi32(oy + oz)), in_i, q011, q111);
          const __m256 m00 = STRATA_LERP(q000, q100, mfx), m10 = STRATA_LERP(q010, q110, mfx);
          const __m256 m01 = STRATA_LERP(q001, q101, mfx), m11 = STRATA_LERP(q011, q111, mfx);
          const __m256 d00 = STRATA_ROWD(0, q000, q100), d10 = STRATA_ROWD(oy, q010, q110);
          const __m256 d01 = STRATA_ROWD(oz, q001, q101), d11 = STRATA_ROWD(oy + oz, q011, q111);
          const __m256 gx0 = STRATA_LERP(d00, d10, mfy), gx1 = STRATA_LERP(d01, d11, mfy);
          gx = STRATA_LERP(gx0, gx1, mfz);
          const __m256 gy0 = STRATA_DIFF(mfy, STRATA_LIN(-oy), m00, m10, STRATA_LIN(2 * oy));
          const __m256 gy1 = STRATA_DIFF(mfy, STRATA_LIN(oz - oy), m01, m11, STRATA_LIN(oz + 2 * oy));
          gy = STRATA_LERP(gy0, gy1, mfz);
          const __m256 gz0 = STRATA_DIFF(mfz, STRATA_LIN(-oz), m00, m01, STRATA_LIN(2 * oz));
          const __m256 gz1 = STRATA_DIFF(mfz, STRATA_LIN(oy - oz), m10, m11, STRATA_LIN(oy + 2 * oz));
          gz = STRATA_LERP(gz0, gz1, mfy);
#undef STRATA_DIFF
#undef STRATA_ROWD
#undef STRATA_LIN
#undef STRATA_LERP
#undef STRATA_G
        }
        // Lanes near the grid's faces take the scalar gradient, one by one; any lane whose stencil
        // met NaN or infinite voxels then takes the scalar march's fallback (one-sided
        // differences toward the finite side).
        const __m256 gsum = _mm256_add_ps(_mm256_add_ps(gx, gy), gz);
        const unsigned rest = want & ~inside;
        const unsigned broken = want & inside & unsigned(_mm256_movemask_ps(_mm256_cmp_ps(_mm256_sub_ps(gsum, gsum), zero, _CMP_NEQ_UQ)));
        if (rest | broken) {
          alignas(32) float gxs[8], gys[8], gzs[8];
          _mm256_store_ps(gxs, gx);
          _mm256_store_ps(gys, gy);
          _mm256_store_ps(gzs, gz);
          for (int l = 0; l < n; ++l)
            if (((rest | broken) >> l) & 1u) {
              float g[3] = {gxs[l], gys[l], gzs[l]};
              if ((rest >> l) & 1u) s.gradient(mxs[l], mys[l], mzs[l], g);
              if (!std::isfinite(g[0]) || !std::isfinite(g[1]) || !std::isfinite(g[2])) s.finite_gradient(mxs[l], mys[l], mzs[l], g);
              gxs[l] = g[0];
              gys[l] = g[1];
              gzs[l] = g[2];
            }
          gx = _mm256_load_ps(gxs);
          gy = _mm256_load_ps(gys);
          gz = _mm256_load_ps(gzs);
        }
        // Blinn-Phong as in Marcher::segment, 8 lanes at once (same operations and order).
        const __m256 g0 = _mm256_mul_ps(gx, _mm256_set1_ps(b.gradient_scale[0]));
        const __m256 g1 = _mm256_mul_ps(gy, _mm256_set1_ps(b.gradient_scale[1]));
        const __m256 g2 = _mm256_mul_ps(gz, _mm256_set1_ps(b.gradient_scale[2]));
        const __m256 len2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(g0, g0), _mm256_mul_ps(g1, g1)), _mm256_mul_ps(g2, g2));
        const __m256 dot = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(g0, _mm256_set1_ps(ray.light[0])),
                                                       _mm256_mul_ps(g1, _mm256_set1_ps(ray.light[1]))),
                                         _mm256_mul_ps(g2, _mm256_set1_ps(ray.light[2])));
        const __m256 ndl = _mm256_div_ps(_mm256_andnot_ps(_mm256_set1_ps(-0.0f), dot), _mm256_sqrt_ps(len2));
        const __m256 diff = _mm256_add_ps(_mm256_set1_ps(mp.light.ambient), _mm256_mul_ps(_mm256_set1_ps(mp.light.diffuse), ndl));
        __m256 pw = one;
        if (mp.light.shininess == detail::kFixedShininess) {  // detail::power_fixed<24>: x^8 * x^16
          static_assert(detail::kFixedShininess == 24);
          const __m256 x2 = _mm256_mul_ps(ndl, ndl), x4 = _mm256_mul_ps(x2, x2), x8 = _mm256_mul_ps(x4, x4);
          pw = _mm256_mul_ps(x8, _mm256_mul_ps(x8, x8));
        } else {  // detail::power
          __m256 base_pw = ndl;
          for (int e = mp.light.shininess; e > 0; e >>= 1) {
            if (e & 1) pw = _mm256_mul_ps(pw, base_pw);
            base_pw = _mm256_mul_ps(base_pw, base_pw);
          }
        }
        const __m256 spec = _mm256_mul_ps(_mm256_mul_ps(_mm256_set1_ps(mp.light.specular), pw), ca);
        // Only lanes asking for shading with a non-zero gradient are shaded (the others may hold
        // garbage here).
        const __m256 lit = _mm256_and_ps(_mm256_cmp_ps(ca, _mm256_set1_ps(lp.shade_threshold), _CMP_GT_OQ),
                                         _mm256_cmp_ps(len2, _mm256_set1_ps(1e-12f), _CMP_GT_OQ));
        cr = _mm256_blendv_ps(cr, _mm256_add_ps(_mm256_mul_ps(cr, diff), spec), lit);
        cg = _mm256_blendv_ps(cg, _mm256_add_ps(_mm256_mul_ps(cg, diff), spec), lit);
        cb = _mm256_blendv_ps(cb, _mm256_add_ps(_mm256_mul_ps(cb, diff), spec), lit);
      }
    }
    // Front-to-back compositing of the 8 segments at once: the transmittance in front of each
    // lane is an exclusive prefix product of (1 - alpha), so the loop-carried chain is one
    // update of `acc` per chunk instead of eight.
    const __m256 through = exclusive_transmittance(_mm256_sub_ps(one, ca));
    const __m256 after = _mm256_mul_ps(through, _mm256_sub_ps(one, ca));  // inclusive
    const float acc_a = _mm_cvtss_f32(_mm_shuffle_ps(acc, acc, 0xff));
    // Opacity after each lane, as compositing lane by lane would give it (up to rounding).
    const __m256 opacity = _mm256_add_ps(_mm256_set1_ps(acc_a),
                                         _mm256_mul_ps(_mm256_set1_ps(1.0f - acc_a), _mm256_sub_ps(one, after)));
    const unsigned done = unsigned(_mm256_movemask_ps(_mm256_cmp_ps(opacity, _mm256_set1_ps(term), _CMP_GT_OQ))) &
                          ((1u << n) - 1u);
    if (done) {  // the ray terminates inside this chunk: lanes after the first opaque one drop out
      const int l = __builtin_ctz(done);
      const __m256 upto = _mm256_castsi256_ps(_mm256_cmpgt_epi32(_mm256_set1_epi32(l + 1), lane_i));
      acc = composite_chunk(acc, _mm256_and_ps(cr, upto), _mm256_and_ps(cg, upto), _mm256_and_ps(cb, upto),
                            _mm256_and_ps(ca, upto), _mm256_and_ps(through, upto));
      front = vs[l];
      last = k + l;
      taken += std::uint64_t(l + 1);
      alignas(16) float out[4];
      _mm_store_ps(out, acc);
      acc_io = {out[0], out[1], out[2], out[3]};
      return k + l + 1;
    }
    acc = composite_chunk(acc, cr, cg, cb, ca, through);
    front = vs[n - 1];
    last = k + n - 1;
    taken += std::uint64_t(n);
    k += n;
  }
  alignas(16) float out[4];
  _mm_store_ps(out, acc);
  acc_io = {out[0], out[1], out[2], out[3]};
  return k;
}
