!> Frequency responses: measured from a record (Welch-averaged spectra,
!> coherence and Bendat & Piersol's random errors) and of a linear model
!> (H (jw I - A)^-1 B + D with its analytic parameter derivatives, so that
!> the Cramer-Rao covariance of a fit gives the sigma of magnitude and phase
!> by the delta method).
!>
!> Spectra are one-sided densities from segments of the record, each with
!> its mean removed and a Hann window, overlapping, transformed by mlid_fft:
!>   G_xy(f) = 2 dt / (L U n_d) sum_segments conj(X(f)) Y(f),  U = mean(w^2),
!> (half that at f = 0 and Nyquist).  H = G_uy / G_uu and gamma^2 =
!> |G_uy|^2 / (G_uu G_yy).  The normalized random error of |H| (Bendat &
!> Piersol, Random Data, table 9.6) is eps = sqrt(1 - gamma^2) /
!> (|gamma| sqrt(2 n_d)); the phase's standard deviation is eps rad.  n_d is
!> the number of segments averaged: with overlap they are not independent,
!> and the errors are those of n_d independent averages (for a Hann window
!> and half overlap the variance is some 6% larger, Welch 1967).
module mlid_freq_response
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_SINGULAR
  use mlid_text, only: es_text, itoa
  use mlid_memory, only: no_memory
  use mlid_fft, only: fft_plan_t, fft_plan, fft_real_pair, fft_length, FFT_WORK_ROWS
  use mlid_models, only: model_t, linear_model_t, layout_t, model_layout
  use mlid_interrupt, only: check_interrupt
  implicit none
  private
  public :: welch_spectra, response_from_spectra, unwrap_deg, model_response, &
            response_bands, segment_count, PI, DB, DEG

  !> Gains in dB and phases in degrees, here and for mlid_transfer_fit and the api.
  real(wp), parameter :: PI = 4.0_wp*atan(1.0_wp)
  real(wp), parameter :: DB = 20.0_wp/log(10.0_wp)     !< dB per neper
  real(wp), parameter :: DEG = 180.0_wp/PI             !< degrees per radian

contains

  !> How many segments of length lseg, overlapping by nover samples, fit in nt.
  pure integer function segment_count(nt, lseg, nover) result(nd)
    integer, intent(in) :: nt, lseg, nover
    nd = 0
    if (lseg < 2 .or. nover < 0 .or. nover >= lseg .or. lseg > nt) return
    nd = (nt - lseg)/(lseg - nover) + 1
  end function segment_count

  !> One-sided auto and cross spectral densities of u and y at the
  !> frequencies k / (nfft dt), k = 1 .. nfft/2 (nfft = fft_length(lseg)):
  !> segments of lseg samples overlapping by nover, Hann-windowed, laid
  !> within each piece of the record (pieces start at samples starts(:),
  !> the manoeuvres of a joined record: no segment spans a join).
  subroutine welch_spectra(u, y, dt, lseg, nover, starts, f, guu, gyy, guy, nd, status, msg)
    real(wp), intent(in) :: u(:), y(:), dt
    integer, intent(in) :: lseg, nover, starts(:)
    real(wp), allocatable, intent(out) :: f(:), guu(:), gyy(:)
    complex(wp), allocatable, intent(out) :: guy(:)
    integer, intent(out) :: nd, status
    character(len=*), intent(out) :: msg
    type(fft_plan_t) :: p
    real(wp), allocatable :: win(:)
    complex(wp), allocatable :: uf(:), yf(:)
    real(wp) :: scale
    integer :: nfft, k, s, j0, piece, ends(size(starts))
    logical :: ok
    status = MLID_OK
    msg = ''
    nd = 0
    ends = [starts(2:) - 1, size(u)]
    k = 0                                                ! the first piece too short, if any
    if (size(starts) > 0) then
      if (starts(1) == 1 .and. all(ends >= starts)) then
        k = findloc([(segment_count(ends(s) - starts(s) + 1, lseg, nover) > 0, &
                      s=1, size(starts))], .false., 1)
        nd = sum([(segment_count(ends(s) - starts(s) + 1, lseg, nover), s=1, size(starts))])
      end if
    end if
    if (size(y) /= size(u) .or. nd < 1 .or. k > 0 .or. .not. dt > 0.0_wp) then
      status = MLID_ERR_INPUT
      s = size(u)
      if (k > 0) s = ends(k) - starts(k) + 1
      write (msg, '(a,i0,a,i0,a,i0,a,i0,a)') 'frequency response: segments of ', lseg, &
        ' samples overlapping by ', nover, ' need a manoeuvre of at least that many (', &
        s, ' in manoeuvre ', max(k, 1), '), 0 <= overlap < segment >= 2 and dt > 0'
      return
    end if
    nfft = fft_length(lseg)
    p = fft_plan(nfft)
    win = [(sin(PI*k/lseg)**2, k=0, lseg - 1)]          ! periodic Hann
    allocate (uf(0:nfft/2), yf(0:nfft/2))
    allocate (guu(nfft/2), gyy(nfft/2), guy(nfft/2))
    guu = 0.0_wp
    gyy = 0.0_wp
    guy = 0.0_wp
    do piece = 1, size(starts)
      do s = 1, segment_count(ends(piece) - starts(piece) + 1, lseg, nover)
        call check_interrupt(status, msg)
        if (status /= MLID_OK) return
        j0 = starts(piece) - 1 + (s - 1)*(lseg - nover)
        call fft_real_pair(p, win*(u(j0 + 1:j0 + lseg) - sum(u(j0 + 1:j0 + lseg))/lseg), &
                           win*(y(j0 + 1:j0 + lseg) - sum(y(j0 + 1:j0 + lseg))/lseg), uf, yf, ok)
        if (.not. ok) then
          call no_memory('the transforms of '//itoa(lseg)//'-sample segments', &
                         real(FFT_WORK_ROWS, wp)*nfft, status, msg)
          return
        end if
        guu = guu + abs(uf(1:))**2
        gyy = gyy + abs(yf(1:))**2
        guy = guy + conjg(uf(1:))*yf(1:)
      end do
    end do
    call check_interrupt(status, msg)                    ! (the last transform cut short)
    if (status /= MLID_OK) return
    scale = 2.0_wp*dt/(lseg*(sum(win**2)/lseg)*nd)
    guu = scale*guu
    gyy = scale*gyy
    guy = scale*guy
    guu(nfft/2) = 0.5_wp*guu(nfft/2)                     ! Nyquist is not doubled
    gyy(nfft/2) = 0.5_wp*gyy(nfft/2)
    guy(nfft/2) = 0.5_wp*guy(nfft/2)
    f = [(k/(nfft*dt), k=1, nfft/2)]
  end subroutine welch_spectra

  !> H = G_uy / G_uu, gamma^2, gain (dB), phase (deg, unwrapped) and their
  !> random errors (one sigma) from n_d averages; NaN where G_uu = 0.
  pure subroutine response_from_spectra(guu, gyy, guy, nd, h, coh, gain, phase, sgain, sphase)
    real(wp), intent(in) :: guu(:), gyy(:)
    complex(wp), intent(in) :: guy(:)
    integer, intent(in) :: nd
    complex(wp), intent(out) :: h(:)
    real(wp), intent(out) :: coh(:), gain(:), phase(:), sgain(:), sphase(:)
    real(wp) :: nan, eps
    integer :: k
    nan = ieee_value(1.0_wp, ieee_quiet_nan)
    do k = 1, size(guu)
      if (guu(k) > 0.0_wp .and. gyy(k) > 0.0_wp) then
        h(k) = guy(k)/guu(k)
        coh(k) = min(1.0_wp, abs(guy(k))**2/(guu(k)*gyy(k)))
        gain(k) = DB*log(abs(h(k)))
        phase(k) = DEG*atan2(aimag(h(k)), real(h(k)))
        eps = sqrt(1.0_wp - coh(k))/(sqrt(coh(k))*sqrt(2.0_wp*nd))
        sgain(k) = DB*eps          ! d(dB) = DB d|H|/|H|
        sphase(k) = DEG*eps
      else
        h(k) = cmplx(nan, nan, wp)
        coh(k) = 0.0_wp
        gain(k) = nan
        phase(k) = nan
        sgain(k) = nan
        sphase(k) = nan
      end if
    end do
    call unwrap_deg(phase)
  end subroutine response_from_spectra

  !> Phase (deg) made continuous along its points: each jump of more than
  !> 180 deg from the last finite point is taken as a wrap of 360.
  pure subroutine unwrap_deg(phase)
    real(wp), intent(inout) :: phase(:)
    real(wp) :: last
    logical :: have
    integer :: k
    have = .false.
    last = 0.0_wp
    do k = 1, size(phase)
      if (phase(k) /= phase(k)) cycle                   ! NaN: skipped
      if (have) phase(k) = phase(k) - 360.0_wp*anint((phase(k) - last)/360.0_wp)
      last = phase(k)
      have = .true.
    end do
  end subroutine unwrap_deg

  !> The frequency response of a linear model (kind 'linear') at w (rad/s):
  !>   T(jw) = C (jw I - A)^-1 B + Dm, with A = F + G K, B = G, C = H + D K,
  !>   Dm = D, times exp(-jw (tau_y(i) + tau_u(j))) for output i, input j
  !> (the layout's output and input delays), and dt(:, :, :, c) = dT/dq(c) for
  !> the columns q(c) of a map jac (nth, nq): dtheta = jac dq (the free
  !> parameters of a fit through its ties).  Entries of theta that do not
  !> enter T (initial states, biases, noise) contribute nothing.
  subroutine model_response(m, theta, w, jac, t, dt, status, msg)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:), w(:), jac(:, :)
    complex(wp), intent(out) :: t(:, :, :), dt(:, :, :, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(layout_t) :: l
    complex(wp), allocatable :: dth(:, :, :)
    integer :: k, c
    status = MLID_OK
    msg = ''
    t = 0.0_wp
    dt = 0.0_wp
    select type (m)
    type is (linear_model_t)
      l = model_layout(m)
      if (size(theta) /= l%nth .or. size(jac, 1) /= l%nth) then
        status = MLID_ERR_INPUT
        write (msg, '(a,i0,a)') 'model frequency response: theta must have ', l%nth, ' values'
        return
      end if
      allocate (dth(m%ny, m%nu, l%nth))
      do k = 1, size(w)
        call response_at(m, l, theta, w(k), t(:, :, k), dth, status, msg)
        if (status /= MLID_OK) return
        do c = 1, size(jac, 2)
          dt(:, :, k, c) = chain(dth, jac(:, c))
        end do
      end do
    class default
      status = MLID_ERR_INPUT
      msg = 'model frequency response: the model must be linear (kind ''linear'')'
    end select
  end subroutine model_response

  !> sum_e d(:, :, e) j(e) over the entries e with j(e) /= 0.
  pure function chain(d, j) result(s)
    complex(wp), intent(in) :: d(:, :, :)
    real(wp), intent(in) :: j(:)
    complex(wp) :: s(size(d, 1), size(d, 2))
    integer :: e
    s = 0.0_wp
    do e = 1, size(j)
      if (j(e) /= 0.0_wp) s = s + j(e)*d(:, :, e)
    end do
  end function chain

  !> T at one frequency and dT/dtheta(e) for every entry e of theta.  With
  !> R = (sI - A)^-1, P = C R and Q = R B (s = jw), the derivatives are
  !>   F(i,j): P(:,i) Q(j,:)                H(i,j): e_i Q(j,:)
  !>   G(i,j): P(:,i) (e_j' + K(j,:) Q)     D(i,j): e_i (e_j' + K(j,:) Q)
  !>   K(i,j): (D(:,i) + P G(:,i)) Q(j,:)
  !> (dA = dF + dG K + G dK, dB = dG, dC = dH + dD K + D dK), before the
  !> delays' factor; a delay's own derivative is -s T of its row or column.
  subroutine response_at(m, l, theta, w, t, dth, status, msg)
    type(linear_model_t), intent(in) :: m
    type(layout_t), intent(in) :: l
    real(wp), intent(in) :: theta(:), w
    complex(wp), intent(out) :: t(:, :), dth(:, :, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: f(m%nx, m%nx), g(m%nx, m%nu), h(m%ny, m%nx), d(m%ny, m%nu), kk(m%nu, m%nx)
    complex(wp) :: r(m%nx, m%nx), p(m%ny, m%nx), pt(m%nx, m%ny), q(m%nx, m%nu), kq(m%nu, m%nu), s
    complex(wp) :: ph(m%ny, m%nu)
    integer :: nx, nu, ny, i, j, info, ipiv(m%nx)
    nx = m%nx
    nu = m%nu
    ny = m%ny
    call m%matrices(theta, f, g, h, d, kk)
    s = cmplx(0.0_wp, w, wp)
    r = -(f + matmul(g, kk))
    do i = 1, nx
      r(i, i) = r(i, i) + s
    end do
    q = g                                               ! Q = (sI - A)^-1 B
    call zgesv(nx, nu, r, nx, ipiv, q, nx, info)
    if (info /= 0) then
      status = MLID_ERR_SINGULAR
      msg = 'model frequency response: jw I - A is singular at w = '//es_text(w, 10, 3)// &
            ' rad/s (a pole on the imaginary axis)'
      return
    end if
    ! P = C R: solve (sI - A)' P' = C' with the same factors
    pt = transpose(h + matmul(d, kk))
    call zgetrs('T', nx, ny, r, nx, ipiv, pt, nx, info)
    p = transpose(pt)
    kq = matmul(kk, q)
    do j = 1, nu
      kq(j, j) = kq(j, j) + 1.0_wp                     ! e_j' + K(j,:) Q, row j
    end do
    t = matmul(h + matmul(d, kk), q) + d
    dth = 0.0_wp
    do j = 1, nx
      do i = 1, nx
        dth(:, :, m%of + (j - 1)*nx + i) = outer(p(:, i), q(j, :))
      end do
      do i = 1, ny
        dth(i, :, m%oh + (j - 1)*ny + i) = q(j, :)
      end do
      do i = 1, nu
        dth(:, :, m%ok + (j - 1)*nu + i) = outer(d(:, i) + matmul(p, g(:, i)), q(j, :))
      end do
    end do
    do j = 1, nu
      do i = 1, nx
        dth(:, :, m%og + (j - 1)*nx + i) = outer(p(:, i), kq(j, :))
      end do
      do i = 1, ny
        dth(i, :, m%od + (j - 1)*ny + i) = kq(j, :)
      end do
    end do
    ! the delays: T(i,j) exp(-s (tau_y(i) + tau_u(j)))
    do j = 1, nu
      do i = 1, ny
        ph(i, j) = exp(-s*(theta(l%odelay + i) + theta(l%oudelay + j)))
      end do
    end do
    t = t*ph
    do i = 1, m%np
      dth(:, :, i) = dth(:, :, i)*ph
    end do
    do i = 1, ny
      dth(i, :, l%odelay + i) = -s*t(i, :)
    end do
    do j = 1, nu
      dth(:, j, l%oudelay + j) = -s*t(:, j)
    end do
    status = MLID_OK
    msg = ''
  end subroutine response_at

  pure function outer(a, b) result(c)
    complex(wp), intent(in) :: a(:), b(:)
    complex(wp) :: c(size(a), size(b))
    integer :: j
    do j = 1, size(b)
      c(:, j) = a*b(j)
    end do
  end function outer

  !> Gain (dB), phase (deg, unwrapped along w) and their sigmas by the delta
  !> method from T (ny, nu, nw), dT/dq (ny, nu, nw, nq) and cov(q):
  !> d gain = DB Re(dT/T), d phase = DEG Im(dT/T).
  pure subroutine response_bands(t, dt, cov, gain, phase, sgain, sphase)
    complex(wp), intent(in) :: t(:, :, :), dt(:, :, :, :)
    real(wp), intent(in) :: cov(:, :)
    real(wp), intent(out), dimension(:, :, :) :: gain, phase, sgain, sphase
    complex(wp) :: z(size(dt, 4))
    integer :: i, j, k
    do k = 1, size(t, 3)
      do j = 1, size(t, 2)
        do i = 1, size(t, 1)
          gain(i, j, k) = DB*log(abs(t(i, j, k)))
          phase(i, j, k) = DEG*atan2(aimag(t(i, j, k)), real(t(i, j, k)))
          z = dt(i, j, k, :)/t(i, j, k)
          sgain(i, j, k) = DB*sqrt(max(0.0_wp, dot_product(real(z), matmul(cov, real(z)))))
          sphase(i, j, k) = DEG*sqrt(max(0.0_wp, dot_product(aimag(z), matmul(cov, aimag(z)))))
        end do
      end do
    end do
    do j = 1, size(t, 2)
      do i = 1, size(t, 1)
        call unwrap_deg(phase(i, j, :))
      end do
    end do
  end subroutine response_bands

end module mlid_freq_response
