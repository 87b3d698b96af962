!> The Kalman filter's covariances (mlid_filter): the measurement update
!> (B, K, P+) and the time update (P-) with their partials, the process
!> noise as it reaches the state over an interval (held noise, or
!> continuous noise by Van Loan's exponential), the effective R and S of
!> outputs that carry the process noise, the steady-state covariance and
!> gain (Riccati and Stein equations), and the covariances' work arrays.
submodule (mlid_filter) mlid_filter_covariance
  use mlid_kinds, only: MLID_ERR_SINGULAR, MLID_ERR_NOCONV
  use mlid_linalg, only: chol_inverse, expm_into
  use mlid_riccati, only: dare_solve, stein_solve
  implicit none

contains

  !> Outputs that carry the process noise of the next interval, (dh/dw) w
  !> (dhw): the effective R and S at this sample (report §5.1.7).
  module procedure output_noise
    status = MLID_OK
    msg = ''
    if (all(dhw == 0.0_wp)) return
    if (code /= 0) then
      status = MLID_ERR_INPUT
      msg = 'outputs that carry the process noise (accelerations) need held noise, '// &
            'process_noise = ''held'''
      return
    end if
    sys%qd(:, :) = matmul(sys%q, transpose(dhw))
    sys%ryy(:, :) = matmul(dhw, sys%qd)
    sys%r(:, :) = sys%r0 + sys%ryy
    sys%s(:, :) = sys%s0 + sys%qd
  end procedure output_noise

  !> Measurement update: B, B^-1, log|B|, K, P+ and their partials.
  module procedure cov_update
    integer :: k, ierr

    status = MLID_OK
    msg = ''
    associate (ct => cv%ct, pct => cv%pct, dpct => cv%dpct, xy => cv%xy, xx => cv%x1, yy => cv%yy)
      ct(:, :) = transpose(sys%c)
      pct(:, :) = matmul(cv%pm, ct)
      yy(:, :) = matmul(sys%c, pct)
      cv%b(:, :) = yy + sys%r
      call symmetrize(cv%b)
      call chol_inverse(cv%b, cv%binv, cv%logdet, ierr)
      if (ierr /= 0) then
        status = MLID_ERR_SINGULAR
        msg = 'innovation covariance B = C P C'' + R is not positive definite'
        return
      end if
      cv%k(:, :) = matmul(pct, cv%binv)
      xx(:, :) = matmul(cv%k, transpose(pct))
      cv%pp(:, :) = cv%pm - xx
      call symmetrize(cv%pp)
      if (.not. partials) return
      do k = 1, size(cv%dpm, 3)
        dpct(:, :) = matmul(cv%dpm(:, :, k), ct)
        if (sys%nz_c(k)) then
          xy(:, :) = matmul(cv%pm, transpose(sys%dc(:, :, k)))
          dpct(:, :) = dpct + xy
        end if
        cv%db(:, :, k) = matmul(sys%c, dpct)
        if (sys%nz_c(k)) then
          yy(:, :) = matmul(sys%dc(:, :, k), pct)
          cv%db(:, :, k) = cv%db(:, :, k) + yy
        end if
        if (sys%nz_r(k)) cv%db(:, :, k) = cv%db(:, :, k) + sys%dr(:, :, k)
        call symmetrize(cv%db(:, :, k))
        xy(:, :) = matmul(cv%k, cv%db(:, :, k))
        xy(:, :) = dpct - xy
        cv%dk(:, :, k) = matmul(xy, cv%binv)
        ! dP+ = dP- - dK (C P-) - K d(C P-), with C P- = pct'
        xx(:, :) = matmul(cv%dk(:, :, k), transpose(pct))
        cv%dpp(:, :, k) = cv%dpm(:, :, k) - xx
        xx(:, :) = matmul(cv%k, transpose(dpct))
        cv%dpp(:, :, k) = cv%dpp(:, :, k) - xx
        call symmetrize(cv%dpp(:, :, k))
      end do
    end associate
  end procedure cov_update

  !> Time update: P- of the next sample from P+ (and the partials),
  !>
  !>   P- = Phi P+ Phi' + V - G B^-1 G' - Phi K G' - G K' Phi'
  !>
  !> with V the process noise as it reaches the state and G = W S its
  !> correlation with the measurement noise (noise_reach); the products
  !> shared by all parameters formed once and zero partials skipped.
  module procedure cov_predict
    integer :: k
    logical :: corr

    corr = any(sys%gs /= 0.0_wp)
    associate (phit => cv%phit, ppt => cv%ppt, a => cv%a, da => cv%da, tmp => cv%tmp, &
               x1 => cv%x1, x2 => cv%x2, gb => cv%gb, yx => cv%yx)
      phit(:, :) = transpose(sys%phi)
      ppt(:, :) = matmul(cv%pp, phit)                        ! P+ Phi'
      tmp(:, :) = matmul(sys%phi, ppt)
      cv%pm(:, :) = tmp + sys%wqw
      if (corr) then
        gb(:, :) = matmul(sys%gs, cv%binv)                   ! G B^-1
        x1(:, :) = matmul(cv%k, transpose(sys%gs))
        a(:, :) = matmul(sys%phi, x1)                        ! Phi K G'
        tmp(:, :) = matmul(gb, transpose(sys%gs))
        cv%pm(:, :) = cv%pm - tmp - a - transpose(a)
      end if
      if (.not. partials) return
      do k = 1, size(cv%dpm, 3)
        x1(:, :) = matmul(cv%dpp(:, :, k), phit)
        tmp(:, :) = matmul(sys%phi, x1)
        if (sys%nz_phi(k)) then
          da(:, :) = matmul(sys%dphi(:, :, k), ppt)
          tmp(:, :) = tmp + da + transpose(da)
        end if
        if (sys%nz_wqw(k)) tmp(:, :) = tmp + sys%dwqw(:, :, k)
        if (corr .or. sys%nz_gs(k)) then
          ! d(G B^-1 G') = dG B^-1 G' + G B^-1 dG' - G B^-1 dB B^-1 G'
          da(:, :) = matmul(sys%dgs(:, :, k), transpose(gb))
          yx(:, :) = matmul(cv%db(:, :, k), transpose(gb))
          x1(:, :) = matmul(gb, yx)
          tmp(:, :) = tmp - da - transpose(da) + x1
          ! d(Phi K G') = dPhi K G' + Phi dK G' + Phi K dG'
          x1(:, :) = matmul(cv%dk(:, :, k), transpose(sys%gs))
          x2(:, :) = matmul(cv%k, transpose(sys%dgs(:, :, k)))
          x1(:, :) = x1 + x2
          da(:, :) = matmul(sys%phi, x1)
          if (sys%nz_phi(k)) then
            x1(:, :) = matmul(cv%k, transpose(sys%gs))
            x2(:, :) = matmul(sys%dphi(:, :, k), x1)
            da(:, :) = da + x2
          end if
          tmp(:, :) = tmp - da - transpose(da)
        end if
        cv%dpm(:, :, k) = tmp
      end do
    end associate
  end procedure cov_predict

  !> a = (a + a')/2 in place: the covariances kept symmetric against rounding.
  pure subroutine symmetrize(a)
    real(wp), intent(inout) :: a(:, :)
    integer :: i, j
    do j = 1, size(a, 2)
      do i = 1, j - 1
        a(i, j) = 0.5_wp*(a(i, j) + a(j, i))
        a(j, i) = a(i, j)
      end do
    end do
  end subroutine symmetrize

  !> V, the process noise as it reaches the state over one interval, and
  !> G = W S: for held noise (code 0) V = W Q W'; for continuous white noise
  !> of density Q (codes 1, 2) V = int_0^dt e^{A s} Gamma Q Gamma' e^{A' s} ds
  !> exactly (van_loan), with a = A and Gamma = df/dw, and G = 0.
  module procedure noise_reach
    status = MLID_OK
    msg = ''
    if (code == 0) then
      sys%qw(:, :) = matmul(sys%q, transpose(sys%w))
      sys%wqw(:, :) = matmul(sys%w, sys%qw)
      sys%gs(:, :) = matmul(sys%w, sys%s)
    else
      sys%qw(:, :) = matmul(sys%q, transpose(sys%g))
      sys%gqg(:, :) = matmul(sys%g, sys%qw)
      call van_loan(a, sys%gqg, sys%dt, sys%wqw, status, msg, sys%vm, sys%ve, sys%ew)
      sys%gs = 0.0_wp
    end if
  end procedure noise_reach

  !> qd = int_0^h e^{A s} v e^{A' s} ds by one matrix exponential (Van Loan,
  !> 1978): e^{M h} with M = [-A, v; 0, A'] holds e^{A' h} and e^{-A h} qd
  !> in its right-hand blocks.  mh, e (2n x 2n) and ew: the caller's work
  !> arrays (the EKF's at every interval).
  subroutine van_loan(a, v, h, qd, status, msg, mh, e, ew)
    real(wp), intent(in) :: a(:, :), v(:, :), h
    real(wp), intent(out) :: qd(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), intent(out) :: mh(:, :), e(:, :)
    type(expm_work_t), intent(inout) :: ew
    integer :: n, info
    n = size(a, 1)
    call van_loan_matrix(a, v, h, mh)
    call expm_into(mh, e, info, ew)
    if (info /= 0) then
      status = MLID_ERR_DIVERGED
      msg = 'continuous process noise: its covariance over a sample interval is not finite'
      qd = 0.0_wp
      return
    end if
    qd = matmul(transpose(e(n + 1:, n + 1:)), e(1:n, n + 1:))
    call symmetrize(qd)
    status = MLID_OK
    msg = ''
  end subroutine van_loan

  !> mh = [-A, v; 0, A'] h (2n x 2n).
  pure module subroutine van_loan_matrix(a, v, h, mh)
    real(wp), intent(in) :: a(:, :), v(:, :), h
    real(wp), intent(out) :: mh(:, :)
    integer :: n
    n = size(a, 1)
    mh = 0.0_wp
    mh(1:n, 1:n) = -a*h
    mh(1:n, n + 1:) = v*h
    mh(n + 1:, n + 1:) = transpose(a)*h
  end subroutine van_loan_matrix

  !> The steady-state P(j|j-1) from the Riccati equation (mlid_riccati) and,
  !> with partials, its partials from the Stein equations; leaves the
  !> update of that P (B, K, P+ and their partials) in cv.
  module procedure steady_state
    real(wp), dimension(size(cv%pm, 1), size(cv%pm, 1)) :: ac, y, pac
    real(wp), dimension(size(cv%k, 1), size(cv%k, 2)) :: kp
    real(wp), allocatable :: e(:, :, :)
    integer :: k, info

    call dare_solve(sys%phi, sys%c, sys%wqw, sys%r, sys%gs, cv%pm, status, msg)
    if (status /= MLID_OK) return
    if (partials) then
      call cov_update(sys, cv, .false., status, msg)
      if (status /= MLID_OK) return
      kp = matmul(matmul(sys%phi, matmul(cv%pm, transpose(sys%c))) + sys%gs, cv%binv)
      ac = sys%phi - matmul(kp, sys%c)
      pac = matmul(cv%pm, transpose(ac))
      allocate (e(size(ac, 1), size(ac, 1), size(cv%dpm, 3)))
      do k = 1, size(e, 3)
        y = 0.0_wp
        if (sys%nz_phi(k)) y = matmul(sys%dphi(:, :, k), pac)
        if (sys%nz_c(k)) y = y - matmul(transpose(pac), matmul(transpose(sys%dc(:, :, k)), &
                                                               transpose(kp)))
        if (sys%nz_gs(k)) y = y - matmul(sys%dgs(:, :, k), transpose(kp))
        e(:, :, k) = y + transpose(y)
        if (sys%nz_wqw(k)) e(:, :, k) = e(:, :, k) + sys%dwqw(:, :, k)
        if (sys%nz_r(k)) e(:, :, k) = e(:, :, k) + matmul(kp, matmul(sys%dr(:, :, k), transpose(kp)))
      end do
      call stein_solve(ac, e, cv%dpm, info)
      if (info /= 0) then
        status = MLID_ERR_NOCONV
        msg = 'steady-state Kalman filter: its closed loop is not stable (no partials of P)'
        return
      end if
    end if
    call cov_update(sys, cv, partials, status, msg)
  end procedure steady_state

  module procedure cov_alloc
    allocate (cv%pm(nx, nx), cv%dpm(nx, nx, nf), cv%pp(nx, nx), cv%dpp(nx, nx, nf), &
              cv%b(ny, ny), cv%binv(ny, ny), cv%db(ny, ny, nf), cv%k(nx, ny), cv%dk(nx, ny, nf))
    allocate (cv%ct(nx, ny), cv%pct(nx, ny), cv%dpct(nx, ny), cv%gb(nx, ny), cv%xy(nx, ny), &
              cv%phit(nx, nx), cv%ppt(nx, nx), cv%a(nx, nx), cv%da(nx, nx), cv%tmp(nx, nx), &
              cv%x1(nx, nx), cv%x2(nx, nx), cv%yy(ny, ny), cv%yx(ny, nx))
    cv%pm = 0.0_wp
    cv%dpm = 0.0_wp
    cv%pp = 0.0_wp
    cv%dpp = 0.0_wp
    cv%db = 0.0_wp
    cv%dk = 0.0_wp
  end procedure cov_alloc

end submodule mlid_filter_covariance
