!> Fourier-transform regression in real time (Morelli, "Real-time parameter
!> estimation in the frequency domain", JGCD 2000; Jategaonkar 2015, sec.
!> 7.4): the discrete Fourier transforms X(w), U(w) of the measured states
!> and inputs over the band w are kept up to date sample by sample,
!>
!>   X(w) <- X(w) + x(k) exp(-i w (t_k - t_1)),
!>
!> and every `every` samples the state equations i w X = F X + G U are
!> solved, equation by equation, by least squares on the real parts:
!>
!>   theta_i = Re(A^H A)^-1 Re(A^H i w X_i),   A = [X U],
!>   s2_i = |i w X_i - A theta_i|^2 / (nw - nx - nu),
!>   sigma_i = sqrt(s2_i diag Re(A^H A)^-1).
!>
!> Every state is measured; every entry of F and G is estimated (no bias
!> terms: the trim, the mean of the first `trim` samples, is removed from
!> x and u first).  The growing transform needs no window: each solve sees
!> the record so far.  With a forgetting factor lambda < 1 the transforms
!> fade, X <- lambda X + x(k) exp(-i w (t_k - t_1)), to track a change:
!> the weights exp(a (t_k - t_n)), a = -ln(lambda)/dt, move the derivative's
!> factor from i w to i w - a (the weighted transform is the transform at
!> the complex frequency w + i a, up to a factor all terms share).  mlid_recursive_fd is its moving-window relative with
!> transient terms.  A solve before the band is excited (Re(A^H A)
!> singular) gives NaN: no estimate yet.
module mlid_ftr
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite, ieee_value, ieee_quiet_nan
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_linalg, only: chol_inverse
  use mlid_text, only: itoa
  implicit none
  private
  public :: ftr_settings_t, ftr_run, ftr_solves

  complex(wp), parameter :: IU = (0.0_wp, 1.0_wp)

  !> The band's frequencies w [rad/s], a solve every `every` samples, the
  !> trim from the mean of the first `trim` samples (0: none) and the first
  !> sample taken into the transforms (the textbook's ftr_mod starts at 2).
  type :: ftr_settings_t
    real(wp), allocatable :: w(:)
    integer :: every = 25
    integer :: trim = 10
    integer :: first = 1
    real(wp) :: lambda = 1.0_wp
  end type ftr_settings_t

contains

  !> The number of solves on n samples.
  pure integer function ftr_solves(n, s) result(m)
    integer, intent(in) :: n
    type(ftr_settings_t), intent(in) :: s
    m = 0
    if (s%every > 0) m = n/s%every
  end function ftr_solves

  !> ts(m), est(np, m), sig(np, m): each solve's time (its last sample's)
  !> and the estimates of F and G with sigma, equation by equation
  !> (F(i, :), then G(i, :) for state i), np = nx (nx + nu), m the solves;
  !> s2(nx, m) each equation's residual variance over the band (the cost).
  subroutine ftr_run(t, x, u, s, ts, est, sig, s2, status, msg)
    real(wp), intent(in) :: t(:), x(:, :), u(:, :)
    type(ftr_settings_t), intent(in) :: s
    real(wp), intent(out) :: ts(:), est(:, :), sig(:, :), s2(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    complex(wp) :: a(size(s%w), size(x, 1) + size(u, 1)), ph(size(s%w)), iw(size(s%w))
    real(wp) :: xt(size(x, 1)), ut(size(u, 1)), z(size(x, 1) + size(u, 1))
    integer :: nx, np, k, m, kt, j

    ts = 0.0_wp
    est = 0.0_wp
    sig = 0.0_wp
    s2 = 0.0_wp
    call check(t, x, u, s, status, msg)
    if (status /= MLID_OK) return
    nx = size(x, 1)
    np = nx + size(u, 1)
    kt = min(max(s%trim, 1), size(t))
    xt = 0.0_wp
    ut = 0.0_wp
    if (s%trim > 0) then
      xt = sum(x(:, 1:kt), dim=2)/kt
      ut = sum(u(:, 1:kt), dim=2)/kt
    end if
    a = 0.0_wp
    m = 0
    iw = IU*s%w + log(s%lambda)/((t(size(t)) - t(1))/(size(t) - 1))
    do k = 1, size(t)
      if (k >= s%first) then
        ph = exp(-IU*s%w*(t(k) - t(1)))
        z = [x(:, k) - xt, u(:, k) - ut]
        do j = 1, np                         ! no temporaries on the per-sample path
          a(:, j) = s%lambda*a(:, j) + ph*z(j)
        end do
      end if
      if (mod(k, s%every) /= 0) cycle
      m = m + 1
      ts(m) = t(k)
      call solve_equations(a, iw, nx, est(:, m), sig(:, m), s2(:, m))
    end do
  end subroutine ftr_run

  !> One solve of iw X_i = [X U] theta_i for each state i over the
  !> transforms so far a = [X U] (nw, nx + nu), iw the derivative's factor
  !> (i w - a); NaN where they do not yet determine theta.
  subroutine solve_equations(a, iw, nx, est, sig, s2)
    complex(wp), intent(in) :: a(:, :), iw(:)
    integer, intent(in) :: nx
    real(wp), intent(out) :: est(:), sig(:), s2(:)
    real(wp) :: nrm(size(a, 2), size(a, 2)), inv(size(a, 2), size(a, 2)), logdet
    complex(wp) :: b(size(iw))
    integer :: i, j, np, info, j0

    np = size(a, 2)
    nrm = real(matmul(conjg(transpose(a)), a), wp)
    call chol_inverse(nrm, inv, logdet, info)
    if (info /= 0) then
      est = ieee_value(1.0_wp, ieee_quiet_nan)
      sig = est
      s2 = est
      return
    end if
    do i = 1, nx
      j0 = (i - 1)*np
      b = iw*a(:, i)
      est(j0 + 1:j0 + np) = matmul(inv, real(matmul(conjg(transpose(a)), b), wp))
      s2(i) = sum(abs(b - matmul(a, cmplx(est(j0 + 1:j0 + np), 0.0_wp, wp)))**2)/(size(iw) - np)
      sig(j0 + 1:j0 + np) = sqrt(max(s2(i), 0.0_wp)*[(inv(j, j), j=1, np)])
    end do
  end subroutine solve_equations

  subroutine check(t, x, u, s, status, msg)
    real(wp), intent(in) :: t(:), x(:, :), u(:, :)
    type(ftr_settings_t), intent(in) :: s
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: np
    status = MLID_ERR_INPUT
    np = size(x, 1) + size(u, 1)
    if (size(x, 1) < 1 .or. size(t) < 2) then
      msg = 'Fourier-transform regression needs a measured state and at least 2 samples'
    else if (size(x, 2) /= size(t) .or. size(u, 2) /= size(t)) then
      msg = 'Fourier-transform regression: the states and inputs need one column per sample'
    else if (.not. allocated(s%w)) then
      msg = 'Fourier-transform regression: no frequencies'
    else if (size(s%w) <= np) then
      msg = 'Fourier-transform regression: '//itoa(size(s%w))//' frequencies for '// &
            itoa(np)//' parameters per equation; more frequencies than parameters are needed'
    else if (.not. (all(ieee_is_finite(s%w)) .and. all(s%w > 0.0_wp))) then
      msg = 'Fourier-transform regression: the frequencies must be > 0 and finite'
    else if (.not. (s%lambda > 0.0_wp .and. s%lambda <= 1.0_wp)) then
      msg = 'Fourier-transform regression: the forgetting factor must be in (0, 1]'
    else if (s%every < 1 .or. s%trim < 0 .or. s%first < 1) then
      msg = 'Fourier-transform regression: the solve interval must be >= 1 sample, the trim '// &
            'samples >= 0 and the first sample >= 1'
    else if (.not. (all(ieee_is_finite(t)) .and. all(ieee_is_finite(x)) .and. &
                    all(ieee_is_finite(u)))) then
      msg = 'Fourier-transform regression: times, states and inputs must be finite'
    else
      status = MLID_OK
      msg = ''
    end if
  end subroutine check

end module mlid_ftr
