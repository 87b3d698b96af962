!> Cramer-Rao covariance corrected for coloured residuals (after Morelli and
!> Klein's residual-autocorrelation correction):
!>
!>     Cov_c = M^-1 [ M - Ms + sum_i sum_j a(i)' w(|i-j|) Rvv(i-j) a(j) ] M^-1
!>
!> a(i) = W(i) S(i), the output (filter error: innovation) sensitivities
!> S(i) = d yhat/d theta (ny x nf) weighted by the inverse noise (innovation)
!> covariance W(i) of the information matrix M; Ms = sum_i S(i)' W(i) S(i)
!> is the part of M the sensitivities make (M - Ms: the a priori weight and
!> the filter-error noise-covariance term, kept as they are);
!> Rvv(k) = (1/N) sum_i v(i) v(i+k)' the residual autocovariance, Rvv(-k) =
!> Rvv(k)'.  Both sums run within each manoeuvre (segment) only.  With
!> Rvv(0) = R, Rvv(k /= 0) = 0 the bracket is M and Cov_c = M^-1.
!>
!> Lags are truncated at L with Bartlett weights w(k) = 1 - k/(L+1): a plain
!> truncation can make the bracket indefinite (negative variances), the
!> triangular window keeps it positive semi-definite (its spectrum, the
!> Fejer kernel, is non-negative).  L is four times the lag by which every
!> output's residual autocorrelation has first come inside the white-noise
!> band +-2/sqrt(N) (with weights 1 - k/(L+1) the lags that carry the
!> correlation keep at least 3/4 of it), at most N/10: beyond that the
!> estimates of Rvv(k) add sampling noise (variance growing like L/N) and
!> little correlation.
!>
!> Cost: the bracket is sum_i a(i)' c(i), c = K * a the convolution of the
!> weighted sensitivities with the kernel K(d) = w(|d|) Rvv(d).  It is taken
!> through the Fourier transform, each manoeuvre zero-padded to the next
!> even length 2^a 3^b 5^c not below its length plus the lag (so the
!> circular convolution is the linear one), by Parseval: (1/n) sum_f
!> A(f)^H K(f) A(f).  That is O(N log N ny nf + N ny^2 nf + N ny nf^2),
!> where the direct FIR filter is O(N L ny^2 nf + N ny nf^2): each segment
!> takes the cheaper (fourier_cheaper).  Rvv is estimated through the
!> transform too, up to the longest lag allowed before the lag is chosen:
!> the transform's length, N plus that lag, is about the bracket's, so
!> stopping at the chosen lag would save little.
module mlid_colored
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_linalg, only: add_sym_atb
  use mlid_fft, only: fft_plan_t, fft_plan_into, fft_many, fft_smooth_length, fft_real_many, &
                     FFT_WORK_ROWS
  use mlid_interrupt, only: check_interrupt, interrupt_requested
  use mlid_memory, only: no_memory
  use mlid_text, only: itoa
  implicit none
  private
  public :: colored_covariance, colored_sandwich, colored_bracket
  public :: BRACKET_AUTO, BRACKET_FOURIER, BRACKET_DIRECT

  !> How the bracket is taken: the cheaper way per segment, or one way.
  integer, parameter :: BRACKET_AUTO = 0, BRACKET_FOURIER = 1, BRACKET_DIRECT = 2

  !> Lag multiple of the first lag inside the white-noise band.
  integer, parameter :: LAG_FACTOR = 4
  !> Longest lag as a fraction 1/LAG_CAP_DIV of the record.
  integer, parameter :: LAG_CAP_DIV = 10
  !> Series the bracket's transform takes at a time: two of mlid_fft's
  !> blocks of 16 (the same blocks as all at once, so the same numbers;
  !> two threads busy), a Ctrl-C seen between them.
  integer, parameter :: CHUNK = 32

contains

  !> The corrected covariance from the residuals v (ny, nt): Rvv estimated
  !> up to the lag (lag_in >= 0, or chosen when lag_in < 0), then the
  !> sandwich.  cov: M^-1 (or its rank-r inverse), info: M, msens: Ms,
  !> a: weighted sensitivities (ny, nt, nf), seg: first sample of each
  !> segment (seg(1) = 1, increasing).
  subroutine colored_covariance(cov, info, msens, a, v, seg, lag_in, cov_c, lag, status, msg)
    real(wp), intent(in) :: cov(:, :), info(:, :), msens(:, :), a(:, :, :)
    real(wp), contiguous, intent(in) :: v(:, :)   !< (a caller's copy: a record's length)
    integer, intent(in) :: seg(:), lag_in
    real(wp), intent(out) :: cov_c(:, :)
    integer, intent(out) :: lag, status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: rvv(:, :, :)

    cov_c = 0.0_wp
    lag = 0
    call check_sizes(a, seg, status, msg)
    if (status /= MLID_OK) return
    if (size(v, 1) /= size(a, 1) .or. size(v, 2) /= size(a, 2)) then
      status = MLID_ERR_INPUT
      msg = 'colored covariance: residuals must be ny x nt like the sensitivities'
      return
    end if
    ! the lag is chosen from the autocorrelations up to the longest allowed
    lag = lag_in
    if (lag < 0) lag = lag_cap(size(v, 2))
    lag = min(lag, size(v, 2) - 1)
    allocate (rvv(size(v, 1), size(v, 1), 0:lag))
    call residual_autocov(v, seg, rvv, status, msg)
    if (status /= MLID_OK) return
    if (lag_in < 0) lag = colored_lag(rvv, size(v, 2))
    call colored_sandwich(cov, info, msens, a, rvv(:, :, 0:lag), seg, cov_c, status, msg)
  end subroutine colored_covariance

  !> Cov_c = cov [info - msens + bracket] cov with Rvv(0:L) given
  !> (Bartlett weights at L = ubound(rvv, 3)).
  subroutine colored_sandwich(cov, info, msens, a, rvv, seg, cov_c, status, msg)
    real(wp), intent(in) :: cov(:, :), info(:, :), msens(:, :), a(:, :, :), rvv(:, :, 0:)
    integer, intent(in) :: seg(:)
    real(wp), intent(out) :: cov_c(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: d(size(a, 3), size(a, 3))
    integer :: nf

    cov_c = 0.0_wp
    nf = size(a, 3)
    call check_sizes(a, seg, status, msg)
    if (status /= MLID_OK) return
    if (any(shape(cov) /= nf) .or. any(shape(info) /= nf) .or. any(shape(msens) /= nf) .or. &
        any(shape(cov_c) /= nf) .or. size(rvv, 1) /= size(a, 1) .or. &
        size(rvv, 2) /= size(a, 1)) then
      status = MLID_ERR_INPUT
      msg = 'colored covariance: cov, info, msens must be nf x nf and Rvv ny x ny'
      return
    end if
    call bracket(a, rvv, seg, BRACKET_AUTO, d, status, msg)
    if (status /= MLID_OK) return
    d = info - msens + d
    cov_c = matmul(cov, matmul(d, cov))
    cov_c = 0.5_wp*(cov_c + transpose(cov_c))   ! symmetric to rounding
  end subroutine colored_sandwich

  !> sum_i sum_j a(i)' K(i-j) a(j) within segments, K(d) = w(|d|) Rvv(d),
  !> Rvv(-k) = Rvv(k)', segment by segment, each by the Fourier transform or
  !> the direct filter, whichever costs less (how = BRACKET_AUTO), or as how
  !> says (the benchmark and the check compare them).
  function colored_bracket(a, rvv, seg, how) result(b)
    real(wp), intent(in) :: a(:, :, :), rvv(:, :, 0:)
    integer, intent(in) :: seg(:), how
    real(wp) :: b(size(a, 3), size(a, 3))
    integer :: status
    character(len=256) :: msg
    call bracket(a, rvv, seg, how, b, status, msg)
  end function colored_bracket

  !> colored_bracket, with a status: the memory of a long record's
  !> transforms, or a Ctrl-C.
  subroutine bracket(a, rvv, seg, how, b, status, msg)
    real(wp), intent(in) :: a(:, :, :), rvv(:, :, 0:)
    integer, intent(in) :: seg(:), how
    real(wp), intent(out) :: b(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: bs(:, :)
    integer, allocatable :: cols(:)
    integer :: s, i0, i1, lag
    logical :: fourier
    b = 0.0_wp
    status = MLID_OK
    msg = ''
    do s = 1, size(seg)
      call segment_bounds(seg, s, size(a, 2), i0, i1)
      lag = min(ubound(rvv, 3), i1 - i0)
      ! the columns that move in this segment (a parameter of another
      ! manoeuvre adds zeros)
      cols = moving_columns(a, i0, i1)
      fourier = how == BRACKET_FOURIER .or. (how == BRACKET_AUTO .and. &
                fourier_cheaper(size(a, 1), i1 - i0 + 1, size(cols), lag))
      if (fourier) then
        call segment_bracket(a(:, i0:i1, :), cols, rvv(:, :, 0:lag), ubound(rvv, 3), bs, status, &
                             msg)
      else
        call segment_direct(a(:, i0:i1, :), cols, rvv(:, :, 0:lag), ubound(rvv, 3), bs, status, &
                            msg)
      end if
      if (status == MLID_OK) call check_interrupt(status, msg)
      if (status /= MLID_OK) return
      b(cols, cols) = b(cols, cols) + bs
    end do
  end subroutine bracket

  !> The columns of a that are not zero in samples i0 .. i1, by loops: an
  !> any() over a section made a temporary of the record's length (an
  !> allocation nothing checks).
  function moving_columns(a, i0, i1) result(cols)
    real(wp), intent(in) :: a(:, :, :)
    integer, intent(in) :: i0, i1
    integer, allocatable :: cols(:)
    logical :: moves(size(a, 3))
    integer :: c, i, r
    moves = .false.
    do c = 1, size(a, 3)
      do i = i0, i1
        do r = 1, size(a, 1)
          if (a(r, i, c) /= 0.0_wp) then
            moves(c) = .true.
            exit
          end if
        end do
        if (moves(c)) exit
      end do
    end do
    cols = pack([(c, c=1, size(a, 3))], moves)
  end function moving_columns

  !> After fft_real_many on n points (what: whose transforms): its workspace that did not
  !> fit in memory (ok false), else a Ctrl-C, as status.
  subroutine after_transforms(ok, what, n, status, msg)
    logical, intent(in) :: ok
    character(len=*), intent(in) :: what
    integer, intent(in) :: n
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    if (ok) then
      call check_interrupt(status, msg)
    else
      call no_memory(what//' of '//itoa(n)//' points', &
                     real(FFT_WORK_ROWS, wp)*n, status, msg)
    end if
  end subroutine after_transforms

  !> Whether the transform costs less than the direct filter for one
  !> segment: each way's loops counted, each count weighted by the
  !> instructions it takes (callgrind, benchmarks/bench_colored_bracket.f90;
  !> the sums below come within 6% (transform) and 20% (filter) of the
  !> measured counts for ny 1-7, N 200-2128, nf 2-30, lags 0-64, before
  !> the series' scaling added some 5 % to the transform).  The
  !> transform: R = ny nf + ny (ny+1)/2 real series of n points (n log2 n
  !> each), K A and A^H G at n/2 + 1 frequencies, and what runs once per
  !> point (the plan, packing, zeroing); the filter: (L+1) ny^2 nf and
  !> ny nf^2 multiply-adds per sample, and its transposes.
  pure logical function fourier_cheaper(ny, nt, nf, lag)
    integer, intent(in) :: ny, nt, nf, lag
    real(wp) :: n, nfreq, y, f, t
    n = real(fft_smooth_length(nt + lag), wp)
    nfreq = real(fft_smooth_length(nt + lag)/2 + 1, wp)
    y = real(ny, wp)
    f = real(nf, wp)
    t = real(nt, wp)
    fourier_cheaper = 1.2_wp*(y*f + y*(y + 1)/2)*n*log(n)/log(2.0_wp) + &
                      30.0_wp*nfreq*y*y*f + 3.7_wp*nfreq*y*f*f + 800.0_wp*n < &
                      3.8_wp*t*(lag + 1)*y*y*f + 1.9_wp*t*y*f*f + 37.0_wp*t*y*f
  end function fourier_cheaper

  !> One segment's bracket (Bartlett weights of lag L; rvv up to the
  !> segment's own longest lag) over the columns cols of a: A(f) = the
  !> transforms of their rows, then Re sum_f A(f)^H K(f) A(f)/n over f = 0
  !> .. n/2, the inner ones twice (f and n - f are conjugate for real
  !> series): Re(A^H G) = Ar' Gr + Ai' Gi, symmetric as K(f) is Hermitian.
  !> A long record's transforms (and a Ctrl-C between them) may end it with
  !> a status; b is then not the bracket.
  subroutine segment_bracket(a, cols, rvv, lag, b, status, msg)
    real(wp), intent(in) :: a(:, :, :), rvv(:, :, 0:)
    integer, intent(in) :: cols(:), lag
    real(wp), allocatable, intent(out) :: b(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: kr(:, :, :), ki(:, :, :), sr(:, :, :), si(:, :, :), gr(:, :, :), &
                             gi(:, :, :), x(:, :)
    type(fft_plan_t) :: plan
    integer :: ny, nt, nf, n, nfreq, l, r, i, q, q0, nq, ist, rq(CHUNK), cq(CHUNK)
    logical :: ok

    status = MLID_OK
    msg = ''
    ny = size(a, 1)
    nt = size(a, 2)
    nf = size(cols)
    allocate (b(nf, nf))
    b = 0.0_wp
    n = fft_smooth_length(nt + ubound(rvv, 3))
    nfreq = n/2 + 1
    call fft_plan_into(n, plan, ok)
    if (.not. ok) then
      call no_memory('the coloured-residual bound''s transform of '//itoa(n)//' points', &
                     2.0_wp*n, status, msg)
      return
    end if
    allocate (kr(nfreq, ny, ny), ki(nfreq, ny, ny), sr(nfreq, ny, nf), si(nfreq, ny, nf), &
              gr(nfreq, ny, nf), gi(nfreq, ny, nf), stat=ist)
    if (ist /= 0) then
      call no_memory('the coloured-residual bound of '//itoa(nt)//' samples x '//itoa(nf)// &
                     ' parameters', real(nfreq, wp)*ny*(4.0_wp*nf + 2*ny), status, msg)
      return
    end if
    call kernel_spectra(plan, rvv, lag, kr, ki, status, msg)
    if (status /= MLID_OK) return
    ! row r of parameter l as series q = r + ny (l - 1), CHUNK series at a time
    do q0 = 1, ny*nf, CHUNK
      nq = min(CHUNK, ny*nf - q0 + 1)
      allocate (x(nq, nt), stat=ist)
      if (ist /= 0) then
        call no_memory('the coloured-residual bound of '//itoa(nt)//' samples', &
                       real(nq, wp)*nt, status, msg)
        return
      end if
      do q = 1, nq                             ! series q0 - 1 + q: row rq of column cq
        l = (q0 + q - 2)/ny + 1
        rq(q) = q0 + q - 1 - ny*(l - 1)
        cq(q) = cols(l)
      end do
      do i = 1, nt                             ! (sample by sample: the cheapest order measured)
        do q = 1, nq
          x(q, i) = a(rq(q), i, cq(q))
        end do
      end do
      r = q0 - ny*((q0 - 1)/ny)
      l = (q0 - 1)/ny + 1
      call fft_real_many(plan, x, sr(1, r, l), si(1, r, l), ok)  ! (series q0 on)
      deallocate (x)
      call after_transforms(ok, 'the coloured-residual bound''s transforms', plan%n, status, msg)
      if (status /= MLID_OK) return
    end do
    ! each parameter's filtered transforms on their own (the result does
    ! not depend on the threads)
    !$omp parallel do private(r) schedule(static)
    do l = 1, nf
      do r = 1, ny - 1, 2                      ! G(f) = K(f) A(f), all f at once, two rows a pass
        if (interrupt_requested()) exit
        call kernel_product(nfreq, ny, kr(:, :, r:r + 1), ki(:, :, r:r + 1), sr(:, :, l), &
                            si(:, :, l), gr(:, r:r + 1, l), gi(:, r:r + 1, l))
      end do
      if (mod(ny, 2) == 1) call kernel_row_product(nfreq, ny, kr(:, :, ny), ki(:, :, ny), &
                                                   sr(:, :, l), si(:, :, l), gr(:, ny, l), gi(:, ny, l))
    end do
    !$omp end parallel do
    call check_interrupt(status, msg)
    if (status /= MLID_OK) return
    call add_sym_atb(nfreq*ny, nf, sr, gr, b)
    call add_sym_atb(nfreq*ny, nf, si, gi, b)
    b = b/real(n, wp)
  end subroutine segment_bracket

  !> The kernel's transform K(f)(r, q) = kr(f, q, r) + i ki(f, q, r) (f = 0
  !> .. n/2; row r of K(f) a contiguous column), the inner frequencies
  !> doubled (f and n - f: the sum over f = 0 .. n/2 counts each twice),
  !> all entries r <= q at once: K(q, r)(d) = K(r, q)(-d), so its transform
  !> is the conjugate.
  subroutine kernel_spectra(plan, rvv, lag, kr, ki, status, msg)
    type(fft_plan_t), intent(in) :: plan
    real(wp), intent(in) :: rvv(:, :, 0:)
    integer, intent(in) :: lag
    real(wp), intent(out) :: kr(0:, :, :), ki(0:, :, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: z(:, :), fr(:, :), fi(:, :)
    integer, allocatable :: pr(:), pq(:)
    integer :: p, r, q, nh, ist
    logical :: ok

    nh = plan%n/2
    status = MLID_OK
    call upper_pairs(size(rvv, 1), pr, pq)
    allocate (z(size(pr), 0:plan%n - 1), fr(0:nh, size(pr)), fi(0:nh, size(pr)), stat=ist)
    if (ist /= 0) then
      call no_memory('the coloured-residual bound''s kernel of '//itoa(plan%n)//' points', &
                     2.0_wp*size(pr)*plan%n, status, msg)
      return
    end if
    z = 0.0_wp
    do p = 1, size(pr)
      call kernel_row(rvv, lag, pr(p), pq(p), z(p, :))
    end do
    call fft_real_many(plan, z, fr, fi, ok)
    call after_transforms(ok, 'the coloured-residual bound''s transforms', plan%n, status, msg)
    if (status /= MLID_OK) return
    fr(1:nh - 1, :) = 2.0_wp*fr(1:nh - 1, :)
    fi(1:nh - 1, :) = 2.0_wp*fi(1:nh - 1, :)
    do p = 1, size(pr)
      r = pr(p)
      q = pq(p)
      kr(:, q, r) = fr(:, p)
      ki(:, q, r) = fi(:, p)
      kr(:, r, q) = fr(:, p)
      ki(:, r, q) = -fi(:, p)
      if (r == q) ki(:, q, r) = 0.0_wp       ! K(r, r)(d) is even: its transform is real
    end do
  end subroutine kernel_spectra

  !> g = sum_q k(:, q) s(:, q) over n frequencies (row r of K(f) times
  !> A(f)), real and imaginary parts apart, two q to a pass (the first q
  !> alone when ny is odd): each pass reads and writes g once.
  pure subroutine kernel_row_product(n, ny, kr, ki, sr, si, gr, gi)
    integer, intent(in) :: n, ny
    real(wp), intent(in) :: kr(n, ny), ki(n, ny), sr(n, ny), si(n, ny)
    real(wp), intent(out) :: gr(n), gi(n)
    integer :: f, q
    q = 1
    if (mod(ny, 2) == 1) then
      gr = kr(:, 1)*sr(:, 1) - ki(:, 1)*si(:, 1)
      gi = kr(:, 1)*si(:, 1) + ki(:, 1)*sr(:, 1)
      q = 2
    else
      gr = 0.0_wp
      gi = 0.0_wp
    end if
    do q = q, ny - 1, 2
      !GCC$ ivdep
      do f = 1, n
        gr(f) = gr(f) + (kr(f, q)*sr(f, q) - ki(f, q)*si(f, q)) + &
                (kr(f, q + 1)*sr(f, q + 1) - ki(f, q + 1)*si(f, q + 1))
        gi(f) = gi(f) + (kr(f, q)*si(f, q) + ki(f, q)*sr(f, q)) + &
                (kr(f, q + 1)*si(f, q + 1) + ki(f, q + 1)*sr(f, q + 1))
      end do
    end do
  end subroutine kernel_row_product

  !> kernel_row_product for two rows at once (k(:, :, 1:2): rows r, r + 1;
  !> g(:, 1:2) theirs), ny >= 2: each pass over the frequencies reads s
  !> once for both; the first pass takes q = 1, 2 (and 3 when ny is odd),
  !> g's first sum as kernel_row_product's, without its store and load.
  pure subroutine kernel_product(n, ny, kr, ki, sr, si, gr, gi)
    integer, intent(in) :: n, ny
    real(wp), intent(in) :: kr(n, ny, 2), ki(n, ny, 2), sr(n, ny), si(n, ny)
    real(wp), intent(out) :: gr(n, 2), gi(n, 2)
    integer :: f, q, j, c
    if (mod(ny, 2) == 1) then
      c = 2                                    ! (k1 s1) + k2 s2 + k3 s3
      !GCC$ ivdep
      do f = 1, n
        do j = 1, 2
          gr(f, j) = (kr(f, 1, j)*sr(f, 1) - ki(f, 1, j)*si(f, 1)) + &
                     (kr(f, 2, j)*sr(f, 2) - ki(f, 2, j)*si(f, 2)) + &
                     (kr(f, 3, j)*sr(f, 3) - ki(f, 3, j)*si(f, 3))
          gi(f, j) = (kr(f, 1, j)*si(f, 1) + ki(f, 1, j)*sr(f, 1)) + &
                     (kr(f, 2, j)*si(f, 2) + ki(f, 2, j)*sr(f, 2)) + &
                     (kr(f, 3, j)*si(f, 3) + ki(f, 3, j)*sr(f, 3))
        end do
      end do
    else
      c = 1                                    ! 0 + k1 s1 + k2 s2
      !GCC$ ivdep
      do f = 1, n
        do j = 1, 2
          gr(f, j) = 0.0_wp + (kr(f, 1, j)*sr(f, 1) - ki(f, 1, j)*si(f, 1)) + &
                     (kr(f, 2, j)*sr(f, 2) - ki(f, 2, j)*si(f, 2))
          gi(f, j) = 0.0_wp + (kr(f, 1, j)*si(f, 1) + ki(f, 1, j)*sr(f, 1)) + &
                     (kr(f, 2, j)*si(f, 2) + ki(f, 2, j)*sr(f, 2))
        end do
      end do
    end if
    do q = c + 2, ny - 1, 2
      !GCC$ ivdep
      do f = 1, n
        gr(f, 1) = gr(f, 1) + (kr(f, q, 1)*sr(f, q) - ki(f, q, 1)*si(f, q)) + &
                   (kr(f, q + 1, 1)*sr(f, q + 1) - ki(f, q + 1, 1)*si(f, q + 1))
        gi(f, 1) = gi(f, 1) + (kr(f, q, 1)*si(f, q) + ki(f, q, 1)*sr(f, q)) + &
                   (kr(f, q + 1, 1)*si(f, q + 1) + ki(f, q + 1, 1)*sr(f, q + 1))
        gr(f, 2) = gr(f, 2) + (kr(f, q, 2)*sr(f, q) - ki(f, q, 2)*si(f, q)) + &
                   (kr(f, q + 1, 2)*sr(f, q + 1) - ki(f, q + 1, 2)*si(f, q + 1))
        gi(f, 2) = gi(f, 2) + (kr(f, q, 2)*si(f, q) + ki(f, q, 2)*sr(f, q)) + &
                   (kr(f, q + 1, 2)*si(f, q + 1) + ki(f, q + 1, 2)*sr(f, q + 1))
      end do
    end do
  end subroutine kernel_product


  !> The kernel entry K(d)(r, q) = w(|d|) Rvv(d)(r, q) at index d mod n of
  !> z (n values, zero elsewhere already), d = -L' .. L' (L' = ubound(rvv, 3)).
  pure subroutine kernel_row(rvv, lag, r, q, z)
    real(wp), intent(in) :: rvv(:, :, 0:)
    integer, intent(in) :: lag, r, q
    real(wp), intent(inout) :: z(0:)
    real(wp) :: w
    integer :: k, n
    n = size(z)
    z(0) = 0.5_wp*(rvv(r, q, 0) + rvv(q, r, 0))   ! Rvv(0) symmetric, as the direct filter takes it
    do k = 1, ubound(rvv, 3)
      w = 1.0_wp - real(k, wp)/real(lag + 1, wp)
      z(k) = w*rvv(r, q, k)
      z(n - k) = w*rvv(q, r, k)              ! Rvv(-k) = Rvv(k)'
    end do
  end subroutine kernel_row

  !> One segment's bracket by the direct FIR filter (Bartlett weights of
  !> lag L; rvv up to the segment's own longest lag) over the columns cols
  !> of a, as P + P' with P = sum_i a(i)' g(i), g(i) = Rvv(0) a(i)/2 + sum_k>0 w(k) Rvv(k)' a(i+k):
  !> the pair (i, j = i+k) gives a(i)' Rvv(-k) a(i+k) = a(i)' Rvv(k)' a(i+k),
  !> the pair (i+k, i) its transpose.
  subroutine segment_direct(a, cols, rvv, lag, b, status, msg)
    real(wp), intent(in) :: a(:, :, :), rvv(:, :, 0:)
    integer, intent(in) :: cols(:), lag
    real(wp), allocatable, intent(out) :: b(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: at(:, :, :), g(:, :, :)
    real(wp) :: w
    integer :: ny, nt, nf, k, l, j, r, ist

    status = MLID_OK
    msg = ''
    ny = size(a, 1)
    nt = size(a, 2)
    nf = size(cols)
    allocate (b(nf, nf))
    b = 0.0_wp
    ! time first (a and g transposed): each term of the filter is one long
    ! contiguous loop over the samples
    allocate (at(nt, ny, nf), g(nt, ny, nf), stat=ist)
    if (ist /= 0) then
      call no_memory('the coloured-residual bound of '//itoa(nt)//' samples x '//itoa(nf)// &
                     ' parameters', 2.0_wp*nt*ny*nf, status, msg)
      return
    end if
    ! each parameter's column on its own (threads share no sum, so the
    ! result does not depend on their number)
    !$omp parallel do private(k, j, r, w) schedule(static)
    do l = 1, nf
      if (interrupt_requested()) cycle
      at(:, :, l) = transpose(a(:, :, cols(l)))
      g(:, :, l) = 0.0_wp
      do k = 0, ubound(rvv, 3)
        w = 1.0_wp - real(k, wp)/real(lag + 1, wp)
        if (k == 0) w = 0.5_wp
        do r = 1, ny
          do j = 1, ny                         ! g(r, i) += w Rvv(k)(j, r) a(j, i+k)
            g(1:nt - k, r, l) = g(1:nt - k, r, l) + (w*rvv(j, r, k))*at(1 + k:nt, j, l)
          end do
        end do
      end do
    end do
    !$omp end parallel do
    call check_interrupt(status, msg)
    if (status /= MLID_OK) return
    call add_sym_atb(ny*nt, nf, at, g, b)      ! P + P', P = A' G: both triangles' dot products
    call add_sym_atb(ny*nt, nf, g, at, b)
  end subroutine segment_direct

  !> Rvv(:, :, k) = (1/N) sum v(i) v(i+k)' over the pairs within one
  !> segment, k = 0 .. ubound(rvv, 3).
  subroutine residual_autocov(v, seg, rvv, status, msg)
    real(wp), contiguous, intent(in) :: v(:, :)
    integer, intent(in) :: seg(:)
    real(wp), intent(out) :: rvv(:, :, 0:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: c(:, :, :)
    integer :: s, i0, i1, nt, lag

    nt = size(v, 2)
    rvv = 0.0_wp
    status = MLID_OK
    msg = ''
    do s = 1, size(seg)
      call segment_bounds(seg, s, nt, i0, i1)
      lag = min(ubound(rvv, 3), i1 - i0)
      call segment_autocov(v(:, i0:i1), lag, c, status, msg)
      if (status == MLID_OK) call check_interrupt(status, msg)
      if (status /= MLID_OK) return
      rvv(:, :, 0:lag) = rvv(:, :, 0:lag) + c
    end do
    rvv = rvv/real(nt, wp)
  end subroutine residual_autocov

  !> One segment's sums c(:, :, k) = sum_i x(i) x(i+k)', k = 0 .. lag
  !> (lag < its length), through the Fourier transform, zero-padded beyond
  !> the length plus the lag: row r's and q's cross-spectrum conj(X_r) X_q
  !> transformed back gives c(r, q, k) at k and c(q, r, k) at n - k; the
  !> pairs r <= q go back two to a transform (each one a real series), the
  !> first half of them in the real parts, the rest in the imaginary parts.
  subroutine segment_autocov(x, lag, c, status, msg)
    real(wp), contiguous, intent(in) :: x(:, :)   !< (no copy for the FFT's contiguous x)
    integer, intent(in) :: lag
    real(wp), allocatable, intent(out) :: c(:, :, :)   !< (ny, ny, 0:lag)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: xr(:, :), xi(:, :), zr(:, :), zi(:, :)
    integer, allocatable :: pr(:), pq(:)
    real(wp), allocatable :: down(:)
    type(fft_plan_t) :: plan
    integer :: ny, n, nh, p, m, ist
    logical :: ok

    status = MLID_OK
    msg = ''
    ny = size(x, 1)
    n = fft_smooth_length(size(x, 2) + lag)
    nh = n/2
    call fft_plan_into(n, plan, ok)
    if (.not. ok) then
      call no_memory('the residual autocorrelations'' transform of '//itoa(n)//' points', &
                     2.0_wp*n, status, msg)
      return
    end if
    call upper_pairs(ny, pr, pq)
    m = (size(pr) + 1)/2
    allocate (c(ny, ny, 0:lag), xr(0:nh, ny), xi(0:nh, ny), zr(m, 0:n - 1), zi(m, 0:n - 1), &
              down(size(pr)), stat=ist)
    if (ist /= 0) then
      call no_memory('the residual autocorrelations of '//itoa(size(x, 2))//' samples', &
                     real(n, wp)*(ny + 2*m), status, msg)
      return
    end if
    call fft_real_many(plan, x, xr, xi, ok)
    call after_transforms(ok, 'the residual autocorrelations'' transforms', plan%n, status, msg)
    if (status /= MLID_OK) return
    do p = 1, size(pr)
      call add_cross(p, xr(:, pr(p)), xi(:, pr(p)), xr(:, pq(p)), xi(:, pq(p)))
    end do
    call fft_many(plan, m, zr, zi)
    do p = 1, m
      call put(pr(p), pq(p), zr(p, :), 1.0_wp/down(p))
    end do
    do p = m + 1, size(pr)
      call put(pr(p), pq(p), zi(p - m, :), 1.0_wp/down(p))
    end do

  contains

    !> Pair p's Q = Xr conj(Xq), the conjugate of the cross-spectrum, over
    !> all n frequencies (Q(n - f) = conj(Q(f)): the series is real), into
    !> the real part of series p (p <= m) or the imaginary part of p - m,
    !> scaled by down(p), a power of two, to a largest value near 1
    !> (exact: the pair's partner may be orders of magnitude larger, and
    !> the transform's rounding is relative to the larger).
    subroutine add_cross(p, ar, ai, br, bi)
      integer, intent(in) :: p
      real(wp), intent(in) :: ar(0:), ai(0:), br(0:), bi(0:)
      real(wp) :: wr(0:nh), wi(0:nh), big, d
      integer :: f
      big = 0.0_wp
      do f = 0, nh
        wr(f) = ar(f)*br(f) + ai(f)*bi(f)
        wi(f) = ai(f)*br(f) - ar(f)*bi(f)
        big = max(big, abs(wr(f)), abs(wi(f)))
      end do
      d = scale(1.0_wp, -exponent(big))
      down(p) = d
      if (p <= m) then                       ! (every entry of rows 1 .. m set here first)
        do f = 0, nh
          zr(p, f) = d*wr(f)
          zi(p, f) = d*wi(f)
        end do
        do f = 1, nh - 1
          zr(p, n - f) = d*wr(f)
          zi(p, n - f) = -(d*wi(f))
        end do
      else                                   ! i Q: i (wr + i wi) = -wi + i wr
        do f = 0, nh
          zr(p - m, f) = zr(p - m, f) - d*wi(f)
          zi(p - m, f) = zi(p - m, f) + d*wr(f)
        end do
        do f = 1, nh - 1
          zr(p - m, n - f) = zr(p - m, n - f) + d*wi(f)
          zi(p - m, n - f) = zi(p - m, n - f) + d*wr(f)
        end do
      end if
    end subroutine add_cross

    !> c's entries of the pair (r, q) from its transform back, cr/n undone
    !> by the factor up (only the lags wanted: the rest is not used).
    subroutine put(r, q, cr, up)
      integer, intent(in) :: r, q
      real(wp), intent(in) :: cr(0:), up
      integer :: k
      c(r, q, 0) = (cr(0)/real(n, wp))*up
      c(q, r, 0) = c(r, q, 0)
      do k = 1, lag
        c(r, q, k) = (cr(k)/real(n, wp))*up
        c(q, r, k) = (cr(n - k)/real(n, wp))*up
      end do
    end subroutine put
  end subroutine segment_autocov

  !> The pairs (pr(p), pq(p)) of 1 .. ny with pr <= pq, row by row.
  pure subroutine upper_pairs(ny, pr, pq)
    integer, intent(in) :: ny
    integer, allocatable, intent(out) :: pr(:), pq(:)
    integer :: r, q
    pr = [((r, q=r, ny), r=1, ny)]
    pq = [((q, q=r, ny), r=1, ny)]
  end subroutine upper_pairs

  !> The longest lag the choice considers: N/LAG_CAP_DIV (at least 1), below N.
  pure integer function lag_cap(nt)
    integer, intent(in) :: nt
    lag_cap = min(max(1, nt/LAG_CAP_DIV), nt - 1)
  end function lag_cap

  !> The lag, from the autocovariance rvv up to lag_cap(nt): LAG_FACTOR
  !> times the lag by which every output's autocorrelation has first come
  !> inside +-2/sqrt(N) (each output its own first crossing: coloured noise
  !> makes the sample autocorrelation at long lags scatter wider than that
  !> band, so all outputs inside it at one lag is a rare event), at most
  !> the cap.
  integer function colored_lag(rvv, nt) result(lag)
    real(wp), intent(in) :: rvv(:, :, 0:)
    integer, intent(in) :: nt
    real(wp) :: c0(size(rvv, 1)), band
    logical :: crossed(size(rvv, 1))
    integer :: k, r

    lag = ubound(rvv, 3)
    c0 = [(rvv(r, r, 0), r=1, size(rvv, 1))]
    if (any(.not. (c0 > 0.0_wp))) return       ! a zero residual: no basis for a choice
    band = 2.0_wp/sqrt(real(nt, wp))
    crossed = .false.
    do k = 1, ubound(rvv, 3)
      crossed = crossed .or. [(abs(rvv(r, r, k)/c0(r)) < band, r=1, size(rvv, 1))]
      if (all(crossed)) then
        lag = min(LAG_FACTOR*k, ubound(rvv, 3))
        return
      end if
    end do
  end function colored_lag

  !> First and last sample of segment s of a record of nt samples.
  pure subroutine segment_bounds(seg, s, nt, i0, i1)
    integer, intent(in) :: seg(:), s, nt
    integer, intent(out) :: i0, i1
    i0 = seg(s)
    i1 = nt
    if (s < size(seg)) i1 = seg(s + 1) - 1
  end subroutine segment_bounds

  !> a is ny x nt x nf with nt >= 1; seg starts at 1 and increases within the record.
  subroutine check_sizes(a, seg, status, msg)
    real(wp), intent(in) :: a(:, :, :)
    integer, intent(in) :: seg(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: nt
    status = MLID_ERR_INPUT
    nt = size(a, 2)
    if (size(a, 1) < 1 .or. nt < 1) then
      msg = 'colored covariance: no samples or no outputs'
    else if (size(seg) < 1) then
      msg = 'colored covariance: no segment starts'
    else if (seg(1) /= 1 .or. any(seg(2:) <= seg(:size(seg) - 1)) .or. seg(size(seg)) > nt) then
      msg = 'colored covariance: segment starts must begin at 1 and increase within the record'
    else
      status = MLID_OK
      msg = ''
    end if
  end subroutine check_sizes

end module mlid_colored
