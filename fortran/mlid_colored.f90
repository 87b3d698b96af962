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
!> Cost: the bracket is sum_i a(i)' g(i) with g(i) = sum_k w(k) Rvv(k)' a(i+k)
!> (a matrix FIR filter of the weighted sensitivities), O(N L ny^2 nf) plus
!> one O(N ny nf^2) product, instead of O(N^2 ny^2 nf^2) for the double sum.
module mlid_colored
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  implicit none
  private
  public :: colored_covariance, colored_sandwich, residual_autocov, colored_lag

  !> Lag multiple of the first lag inside the white-noise band.
  integer, parameter :: LAG_FACTOR = 4
  !> Longest lag as a fraction 1/LAG_CAP_DIV of the record.
  integer, parameter :: LAG_CAP_DIV = 10

contains

  !> The corrected covariance from the residuals v (ny, nt): Rvv estimated
  !> up to the lag (lag_in >= 0, or chosen when lag_in < 0), then the
  !> sandwich.  cov: M^-1 (or its rank-r inverse), info: M, msens: Ms,
  !> a: weighted sensitivities (ny, nt, nf), seg: first sample of each
  !> segment (seg(1) = 1, increasing).
  subroutine colored_covariance(cov, info, msens, a, v, seg, lag_in, cov_c, lag, status, msg)
    real(wp), intent(in) :: cov(:, :), info(:, :), msens(:, :), a(:, :, :), v(:, :)
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
    lag = lag_in
    if (lag < 0) lag = colored_lag(v, seg)
    lag = min(lag, size(v, 2) - 1)
    allocate (rvv(size(v, 1), size(v, 1), 0:lag))
    call residual_autocov(v, seg, rvv)
    call colored_sandwich(cov, info, msens, a, rvv, seg, cov_c, status, msg)
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
    d = info - msens + bracket(a, rvv, seg)
    cov_c = matmul(cov, matmul(d, cov))
    cov_c = 0.5_wp*(cov_c + transpose(cov_c))   ! symmetric to rounding
  end subroutine colored_sandwich

  !> sum_i sum_j a(i)' w(|i-j|) Rvv(i-j) a(j) within segments, as P + P'
  !> with P = sum_i a(i)' g(i), g(i) = Rvv(0) a(i)/2 + sum_k>0 w(k) Rvv(k)' a(i+k):
  !> the pair (i, j = i+k) gives a(i)' Rvv(-k) a(i+k) = a(i)' Rvv(k)' a(i+k),
  !> the pair (i+k, i) its transpose.
  function bracket(a, rvv, seg) result(b)
    real(wp), intent(in) :: a(:, :, :), rvv(:, :, 0:)
    integer, intent(in) :: seg(:)
    real(wp) :: b(size(a, 3), size(a, 3))
    real(wp), allocatable :: g(:, :, :), rk(:, :, :)
    integer :: ny, nt, nf, lag, k, l, s, i0, i1

    ny = size(a, 1)
    nt = size(a, 2)
    nf = size(a, 3)
    lag = ubound(rvv, 3)
    allocate (g(ny, nt, nf), rk(ny, ny, 0:lag))
    do k = 0, lag
      rk(:, :, k) = (1.0_wp - real(k, wp)/real(lag + 1, wp))*transpose(rvv(:, :, k))
    end do
    rk(:, :, 0) = 0.5_wp*rk(:, :, 0)
    ! each parameter's column on its own (threads share no sum, so the
    ! result does not depend on their number)
    !$omp parallel do private(k, s, i0, i1) schedule(static)
    do l = 1, nf
      g(:, :, l) = 0.0_wp
      do s = 1, size(seg)
        call segment_bounds(seg, s, nt, i0, i1)
        do k = 0, min(lag, i1 - i0)
          call add_product(ny, i1 - i0 + 1 - k, rk(:, :, k), a(:, i0 + k:i1, l), &
                           g(:, i0:i1 - k, l))
        end do
      end do
      do k = 1, nf
        b(k, l) = sum(a(:, :, k)*g(:, :, l))
      end do
    end do
    !$omp end parallel do
    b = b + transpose(b)
  end function bracket

  !> y = y + r x on contiguous blocks of columns (x, y: n x m).
  pure subroutine add_product(n, m, r, x, y)
    integer, intent(in) :: n, m
    real(wp), intent(in) :: r(n, n), x(n, m)
    real(wp), intent(inout) :: y(n, m)
    integer :: c, j
    do c = 1, m                     ! in place: no temporary of the product
      do j = 1, n
        y(:, c) = y(:, c) + r(:, j)*x(j, c)
      end do
    end do
  end subroutine add_product

  !> Rvv(:, :, k) = (1/N) sum v(i) v(i+k)' over the pairs within one
  !> segment, k = 0 .. ubound(rvv, 3).
  subroutine residual_autocov(v, seg, rvv)
    real(wp), intent(in) :: v(:, :)
    integer, intent(in) :: seg(:)
    real(wp), intent(out) :: rvv(:, :, 0:)
    integer :: k, s, i0, i1, nt

    nt = size(v, 2)
    rvv = 0.0_wp
    do s = 1, size(seg)
      call segment_bounds(seg, s, nt, i0, i1)
      do k = 0, min(ubound(rvv, 3), i1 - i0)
        rvv(:, :, k) = rvv(:, :, k) + matmul(v(:, i0:i1 - k), transpose(v(:, i0 + k:i1)))
      end do
    end do
    rvv = rvv/real(nt, wp)
  end subroutine residual_autocov

  !> The lag: LAG_FACTOR times the lag by which every output's
  !> autocorrelation has first come inside +-2/sqrt(N) (each output its own
  !> first crossing: coloured noise makes the sample autocorrelation at
  !> long lags scatter wider than that band, so all outputs inside it at
  !> one lag is a rare event), at most N/LAG_CAP_DIV.
  integer function colored_lag(v, seg) result(lag)
    real(wp), intent(in) :: v(:, :)
    integer, intent(in) :: seg(:)
    real(wp) :: c0(size(v, 1)), ck(size(v, 1)), band
    logical :: crossed(size(v, 1))
    integer :: k, s, i0, i1, nt, cap

    nt = size(v, 2)
    cap = max(1, nt/LAG_CAP_DIV)
    lag = min(cap, nt - 1)
    c0 = sum(v**2, dim=2)
    if (any(.not. (c0 > 0.0_wp))) return       ! a zero residual: no basis for a choice
    band = 2.0_wp/sqrt(real(nt, wp))
    crossed = .false.
    do k = 1, cap
      ck = 0.0_wp
      do s = 1, size(seg)
        call segment_bounds(seg, s, nt, i0, i1)
        if (i1 - i0 >= k) ck = ck + sum(v(:, i0:i1 - k)*v(:, i0 + k:i1), dim=2)
      end do
      crossed = crossed .or. abs(ck/c0) < band
      if (all(crossed)) then
        lag = min(LAG_FACTOR*k, cap, nt - 1)
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
