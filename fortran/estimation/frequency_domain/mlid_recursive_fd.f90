!> Recursive frequency-domain equation error over a moving window: the
!> window's Fourier transform kept up to date sample by sample (each
!> frequency's sum of x_j exp(-i w t_j) gains the new sample and loses the
!> one leaving: a complex multiply-add each, the phase itself one complex
!> multiply), and every stride samples the state equations i w X = F X + G U
!> solved by least squares over the window's transform.
!>
!> The window's transform is mlid_fourier's (the sum times W(w dt) plus the
!> end-point terms of the window's first and last samples, exact for the
!> straight lines between them) and each state equation carries the
!> transient terms of mlid_frequency's equation error (x(t0), x(t1),
!> constant forcing and drift rate: basis exp(-i w t0), -exp(-i w t1), E,
!> R), so a window that covers the whole record gives mlid_frequency's
!> estimates and Cramer-Rao sigmas: the weights c = min(1, df T) times (N -
!> p)/N with N = 2 nx sum c over the equations, p the parameters and
!> transient terms, and S_i = (1/n) sum c |V_i|^2 per state equation.
!> Every state is measured (x, in the model's state order); the fixed
!> entries of F and G move to the left-hand side.
module mlid_recursive_fd
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_SINGULAR
  use mlid_fourier, only: fourier_weights
  use mlid_linalg, only: chol_inverse
  use mlid_sampling, only: record_uniform_step
  use mlid_interrupt, only: check_interrupt, POLL_MASK
  implicit none
  private
  public :: recursive_fdee

  complex(wp), parameter :: IU = (0.0_wp, 1.0_wp)
  !> The phases are recomputed from the time every so many samples: the
  !> product of unit rotations drifts by a rounding error per sample.
  integer, parameter :: REPHASE = 256
  integer, parameter :: NTRANS = 4     !< transient terms per state equation

contains

  !> est, sig (np, nwin): the free entries' estimates and Cramer-Rao sigmas
  !> (F's free entries column by column, then G's) in each window, tend
  !> (nwin) its last sample's time; window and stride in samples, w (rad/s).
  subroutine recursive_fdee(t, x, u, f0, g0, freef, freeg, w, window, stride, tend, est, sig, &
                            status, msg)
    real(wp), intent(in) :: t(:), x(:, :), u(:, :), f0(:, :), g0(:, :), w(:)
    logical, intent(in) :: freef(:, :), freeg(:, :)
    integer, intent(in) :: window, stride
    real(wp), intent(out) :: tend(:), est(:, :), sig(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    complex(wp) :: s(size(w), size(x, 1) + size(u, 1)), ph(size(w)), rot(size(w)), back(size(w))
    real(wp) :: z(size(x, 1) + size(u, 1), size(t)), dt
    integer :: nx, nu, nt, n, j, k, iw

    nx = size(x, 1)
    nu = size(u, 1)
    nt = size(t)
    tend = 0.0_wp
    est = 0.0_wp
    sig = 0.0_wp
    status = MLID_ERR_INPUT
    if (window < 3 .or. window > nt .or. stride < 1) then
      write (msg, '(a,i0,a,i0,a,i0)') 'the window must hold 3 to ', nt, ' samples and the stride '// &
        'be at least 1, got ', window, ' and ', stride
      return
    end if
    call record_uniform_step(t, dt, status, msg)
    if (status /= MLID_OK) return
    status = MLID_ERR_INPUT
    if (maxval(w) >= acos(-1.0_wp)/dt .or. minval(w) <= 0.0_wp) then
      msg = 'the frequencies must lie between zero and the Nyquist frequency'
      return
    else if (size(tend) /= (nt - window)/stride + 1) then
      write (msg, '(a,i0)') 'windows: ', (nt - window)/stride + 1
      return
    end if
    z(:nx, :) = x
    z(nx + 1:, :) = u
    rot = exp(-IU*w*dt)
    back = exp(IU*w*(window*dt))            ! exp(-i w t_{j-window}) from exp(-i w t_j)
    s = 0.0_wp
    iw = 0
    do j = 1, nt
      if (iand(j, POLL_MASK) == 0) then
        status = MLID_OK
        call check_interrupt(status, msg)
        if (status /= MLID_OK) return
      end if
      if (mod(j - 1, REPHASE) == 0) then
        ph = exp(-IU*w*t(j))
      else
        ph = ph*rot
      end if
      do k = 1, size(w)                     ! the sample entering, and the one leaving
        s(k, :) = s(k, :) + z(:, j)*ph(k)
        if (j > window) s(k, :) = s(k, :) - z(:, j - window)*(ph(k)*back(k))
      end do
      n = j - window + 1
      if (n < 1 .or. mod(n - 1, stride) /= 0) cycle
      iw = iw + 1
      tend(iw) = t(j)
      call window_fit(s, z(:, n), z(:, j), t(n), t(j), dt, w, nx, f0, g0, freef, freeg, &
                      est(:, iw), sig(:, iw), status, msg)
      if (status /= MLID_OK) return
    end do
  end subroutine recursive_fdee

  !> One window's transform from its sums (the first and last samples' end
  !> terms added) and each state equation's least squares.
  subroutine window_fit(s, z0, z1, t0, t1, dt, w, nx, f0, g0, freef, freeg, est, sig, status, msg)
    complex(wp), intent(in) :: s(:, :)
    real(wp), intent(in) :: z0(:), z1(:), t0, t1, dt, w(:), f0(:, :), g0(:, :)
    integer, intent(in) :: nx
    logical, intent(in) :: freef(:, :), freeg(:, :)
    real(wp), intent(out) :: est(:), sig(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    complex(wp) :: zf(size(w), size(z0)), a, p0, p1, e
    complex(wp), allocatable :: reg(:, :)
    complex(wp) :: lhs(size(w))
    real(wp), allocatable :: ar(:, :), m(:, :), c(:, :), coef(:), res(:)
    real(wp) :: wt, cw, nsum, dof, ssq(nx), ld
    integer :: k, i, j, np, ip, nk, ierr, cols(size(z0)), ptot, col0
    type :: eq_t
      real(wp), allocatable :: c(:, :), coef(:)
      integer, allocatable :: cols(:)
      integer :: np = 0
    end type eq_t
    type(eq_t) :: eq(nx)

    nk = size(w)
    do k = 1, nk
      call fourier_weights(w(k)*dt, wt, a)
      zf(k, :) = dt*(wt*s(k, :) + (a - wt)*z0*exp(-IU*w(k)*t0) + (conjg(a) - wt)*z1*exp(-IU*w(k)*t1))
    end do
    ! weight of each frequency: min(1, df T)
    cw = 1.0_wp
    if (nk > 1) cw = min(1.0_wp, (maxval(w) - minval(w))/(nk - 1)/(2.0_wp*acos(-1.0_wp))*(t1 - t0))
    nsum = nk*cw
    ptot = 0
    do i = 1, nx                            ! each state equation: its own least squares
      np = count(freef(i, :)) + count(freeg(i, :))
      cols(:np) = pack([(j, j=1, size(z0))], [freef(i, :), freeg(i, :)])
      allocate (reg(nk, np + NTRANS), ar(2*nk, np + NTRANS))
      do k = 1, nk
        p0 = exp(-IU*w(k)*t0)
        p1 = exp(-IU*w(k)*t1)
        e = (p0 - p1)/(IU*w(k))
        reg(k, :np) = zf(k, cols(:np))
        reg(k, np + 1:) = [p0, -p1, e, (e - (t1 - t0)*p1)/(IU*w(k))]
        lhs(k) = IU*w(k)*zf(k, i) - sum(f0(i, :)*merge(0.0_wp, 1.0_wp, freef(i, :))*zf(k, :nx)) &
                 - sum(g0(i, :)*merge(0.0_wp, 1.0_wp, freeg(i, :))*zf(k, nx + 1:))
      end do
      ar(:nk, :) = real(reg, wp)
      ar(nk + 1:, :) = aimag(reg)
      m = matmul(transpose(ar), ar)
      allocate (c(np + NTRANS, np + NTRANS))
      call chol_inverse(m, c, ld, ierr)
      if (ierr /= 0) then
        status = MLID_ERR_SINGULAR
        write (msg, '(a,i0,a,g0.6,a)') 'state equation ', i, ': its regressors are dependent '// &
          'in the window ending at ', t1, ' s'
        return
      end if
      coef = matmul(c, matmul(transpose(ar), [real(lhs, wp), aimag(lhs)]))
      res = [real(lhs, wp), aimag(lhs)] - matmul(ar, coef)
      ssq(i) = sum(res**2)
      eq(i)%c = c
      eq(i)%coef = coef
      eq(i)%cols = cols(:np)
      eq(i)%np = np
      ptot = ptot + np + NTRANS
      deallocate (reg, ar, c)
    end do
    ! the estimates in the order of the free entries (F column by column, then G)
    dof = 2.0_wp*nx*nsum - ptot
    if (.not. dof > 0.0_wp) then
      status = MLID_ERR_INPUT
      msg = 'the window holds too few independent frequencies for the parameters and '// &
            'transient terms: lengthen it or widen the band'
      return
    end if
    ip = 0
    do col0 = 1, size(z0)
      do i = 1, nx
        if (col0 <= nx) then
          if (.not. freef(i, col0)) cycle
        else
          if (.not. freeg(i, col0 - nx)) cycle
        end if
        ip = ip + 1
        j = findloc(eq(i)%cols, col0, 1)
        est(ip) = eq(i)%coef(j)
        ! S_i = (2/n) sum c |V|^2 / 2 per real pair; information 2 c' A'A / S_i
        sig(ip) = sqrt(eq(i)%c(j, j)*(ssq(i)*cw/nsum)/(2.0_wp*cw*dof/(2.0_wp*nx*nsum)))
      end do
    end do
    status = MLID_OK
    msg = ''
  end subroutine window_fit

end module mlid_recursive_fd
